#!/usr/bin/env python3
"""Reference distances between the collision geometries of the Panda, the UR5 and the iiwa 14,
computed by coal (Pinocchio's collision library) for the tests of chasles's distance engine.

Every mesh becomes the convex hull of its vertices (qhull, through coal's
BVHModel.buildConvexHull); boxes, cylinders and spheres stay coal's exact primitives. For N
random configurations (splitmix64, seed 0x5EED0000 + r) it records the signed distance of every
pair (negative: penetration depth, from coal's EPA) and, for the first configurations, the
witness points in the world (base) frame. Output and format: tests/data/collision/README.md.

Run from the repository root with the project's Pinocchio venv (tools/pinocchio.sh):

    tools/pinocchio.sh >/dev/null
    build-bench/venv/bin/python tools/reference/coal_distances.py
"""
import argparse
import json
import math
import os
import sys
import xml.etree.ElementTree as ET
from importlib.metadata import version

import coal
import numpy as np
import pinocchio as pin

MASK = (1 << 64) - 1
SEED_BASE = 0x5EED0000

ROBOTS = [
    # (name in the output, r in the seed, URDF, SRDF under the robots dir or None, chain joints)
    ("panda", 0, "panda.urdf",
     "example-robot-data/robots/panda_description/srdf/panda.srdf",
     [f"panda_joint{i}" for i in range(1, 8)]),
    ("ur5", 1, "ur5.urdf",
     "example-robot-data/robots/ur_description/srdf/ur5.srdf",
     ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
      "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]),
    ("iiwa", 2, "iiwa14.urdf", None, [f"iiwa_joint_{i}" for i in range(1, 8)]),
]


class SplitMix64:
    def __init__(self, seed):
        self.x = seed & MASK

    def next(self):
        self.x = (self.x + 0x9E3779B97F4A7C15) & MASK
        z = self.x
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
        return z ^ (z >> 31)

    def uniform(self):
        return (self.next() >> 11) * 2.0**-53


def configurations(seed, limits, n):
    g = SplitMix64(seed)
    qs = np.empty((n, len(limits)))
    for c in range(n):
        for i, (lo, hi) in enumerate(limits):
            qs[c, i] = lo + g.uniform() * (hi - lo)
    return qs


# ---- the URDF, read independently of Pinocchio -------------------------------------------------

def floats(s, default):
    return [float(v) for v in s.split()] if s is not None else list(default)


def rpy_matrix(r, p, y):
    # URDF: R = Rz(yaw) Ry(pitch) Rx(roll)
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def origin_transform(elem):
    o = elem.find("origin") if elem is not None else None
    xyz = floats(o.get("xyz") if o is not None else None, (0, 0, 0))
    rpy = floats(o.get("rpy") if o is not None else None, (0, 0, 0))
    t = np.eye(4)
    t[:3, :3] = rpy_matrix(*rpy)
    t[:3, 3] = xyz
    return t


def axis_angle(axis, a):
    k = np.asarray(axis) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * kx + (1 - math.cos(a)) * kx @ kx


class Urdf:
    def __init__(self, path):
        root = ET.parse(path).getroot()
        self.links = [l.get("name") for l in root.findall("link")]
        self.collisions = []  # (link, k, origin 4x4, geometry dict) in document order
        for l in root.findall("link"):
            for k, c in enumerate(l.findall("collision")):
                g = c.find("geometry")[0]
                geom = {"tag": g.tag}
                if g.tag == "box":
                    geom["size"] = floats(g.get("size"), ())
                elif g.tag == "cylinder":
                    geom["radius"], geom["length"] = float(g.get("radius")), float(g.get("length"))
                elif g.tag == "sphere":
                    geom["radius"] = float(g.get("radius"))
                elif g.tag == "mesh":
                    geom["filename"] = g.get("filename")
                    geom["scale"] = floats(g.get("scale"), (1, 1, 1))
                else:
                    raise ValueError(f"{path}: {l.get('name')}: unknown geometry {g.tag}")
                self.collisions.append((l.get("name"), k, origin_transform(c), geom))
        self.joints = {}
        for j in root.findall("joint"):
            lim = j.find("limit")
            ax = j.find("axis")
            self.joints[j.get("name")] = {
                "type": j.get("type"),
                "parent": j.find("parent").get("link"),
                "child": j.find("child").get("link"),
                "origin": origin_transform(j),
                "axis": floats(ax.get("xyz") if ax is not None else None, (1, 0, 0)),
                "limits": (float(lim.get("lower", 0)), float(lim.get("upper", 0))) if lim is not None else None,
            }
        self.parent_joint = {j["child"]: n for n, j in self.joints.items()}

    def link_poses(self, q_by_joint):
        """World pose of every link; joints not in q_by_joint at 0."""
        poses = {}

        def pose(link):
            if link in poses:
                return poses[link]
            jn = self.parent_joint.get(link)
            if jn is None:
                poses[link] = np.eye(4)
                return poses[link]
            j = self.joints[jn]
            m = np.eye(4)
            a = q_by_joint.get(jn, 0.0)
            if j["type"] in ("revolute", "continuous"):
                m[:3, :3] = axis_angle(j["axis"], a)
            elif j["type"] == "prismatic":
                m[:3, 3] = a * np.asarray(j["axis"]) / np.linalg.norm(j["axis"])
            elif j["type"] != "fixed":
                raise ValueError(f"joint {jn}: type {j['type']}")
            poses[link] = pose(j["parent"]) @ j["origin"] @ m
            return poses[link]

        for l in self.links:
            pose(l)
        return poses


def srdf_disabled(path):
    root = ET.parse(path).getroot()
    return {frozenset((d.get("link1"), d.get("link2"))) for d in root.findall("disable_collisions")}


# ---- the geometry ------------------------------------------------------------------------------

def se3_matrix(m):
    t = np.eye(4)
    t[:3, :3] = m.rotation
    t[:3, 3] = m.translation
    return t


def inside(go, pose_world, p, eps):
    """Whether world point p lies in (or on) geometry go placed at pose_world, within eps."""
    local = pose_world[:3, :3].T @ (np.asarray(p) - pose_world[:3, 3])
    g = go.geometry
    if isinstance(g, coal.Box):
        return bool(np.all(np.abs(local) <= np.asarray(g.halfSide) + eps))
    if isinstance(g, coal.Cylinder):
        return bool(math.hypot(local[0], local[1]) <= g.radius + eps and abs(local[2]) <= g.halfLength + eps)
    if isinstance(g, coal.Sphere):
        return bool(np.linalg.norm(local) <= g.radius + eps)
    # coal's ConvexBase: outward unit normals n_f and offsets o_f, with n_f . x + o_f <= 0 inside
    return bool(np.max(np.asarray(g.normals()) @ local + np.asarray(g.offsets()).ravel()) <= eps)


def support(go):
    """h(D): the support function of go in its own frame, for the rows of D (unit directions)."""
    g = go.geometry
    if isinstance(g, coal.Box):
        h = np.asarray(g.halfSide, dtype=float)
        return lambda d: np.abs(d) @ h
    if isinstance(g, coal.Cylinder):
        r, hl = float(g.radius), float(g.halfLength)
        return lambda d: r * np.hypot(d[:, 0], d[:, 1]) + hl * np.abs(d[:, 2])
    if isinstance(g, coal.Sphere):
        r = float(g.radius)
        return lambda d: r * np.linalg.norm(d, axis=1)
    pts = np.asarray(g.points(), dtype=float)
    return lambda d: np.max(d @ pts.T, axis=1)


def world_support(h, pose, dirs):
    """h_world(u) = u . t + h_local(R^T u) for the rows u of dirs."""
    return dirs @ pose[:3, 3] + h(dirs @ pose[:3, :3])


def sphere_directions(n):
    """n unit vectors spread over the sphere (Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = k * math.pi * (3 - math.sqrt(5))
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def object_entry(name, link, go, hull_of):
    g = go.geometry
    e = {"name": name, "link": link}
    if isinstance(g, coal.Box):
        e.update(type="box", size=[2 * float(h) for h in g.halfSide])
    elif isinstance(g, coal.Cylinder):
        e.update(type="cylinder", radius=float(g.radius), length=2 * float(g.halfLength))
    elif isinstance(g, coal.Sphere):
        e.update(type="sphere", radius=float(g.radius))
    else:
        e.update(type="convex", hull_vertices=int(g.num_points), mesh=hull_of)
    return e


def check_geometry(urdf_geom, go, robots_dir, mesh_paths):
    """The Pinocchio object is the URDF element: same kind and dimensions, same mesh file."""
    g = go.geometry
    tag = urdf_geom["tag"]
    if tag == "box":
        assert isinstance(g, coal.Box), go.name
        assert np.allclose(2 * np.asarray(g.halfSide), urdf_geom["size"], rtol=0, atol=1e-15), go.name
    elif tag == "cylinder":
        assert isinstance(g, coal.Cylinder), go.name
        assert abs(g.radius - urdf_geom["radius"]) <= 1e-15 and abs(2 * g.halfLength - urdf_geom["length"]) <= 1e-15, go.name
    elif tag == "sphere":
        assert isinstance(g, coal.Sphere) and abs(g.radius - urdf_geom["radius"]) <= 1e-15, go.name
    else:
        assert isinstance(g, coal.BVHModelBase), (go.name, type(g))
        uri = urdf_geom["filename"]
        assert uri.startswith("package://"), uri
        expect = os.path.join(robots_dir, uri[len("package://"):])
        assert os.path.isfile(expect), expect
        assert os.path.realpath(go.meshPath) == os.path.realpath(expect), (go.meshPath, expect)
        assert np.allclose(go.meshScale, urdf_geom["scale"]), go.name
        mesh_paths.append(go.meshPath)


def run_robot(spec, args):
    name, r, urdf_file, srdf_rel, chain = spec
    robots_dir = os.path.abspath(args.robots)
    urdf_path = os.path.join(robots_dir, urdf_file)
    srdf_path = os.path.join(robots_dir, srdf_rel) if srdf_rel else None
    urdf = Urdf(urdf_path)

    model, gmodel = pin.buildModelsFromUrdf(urdf_path, package_dirs=[robots_dir],
                                            geometry_types=pin.GeometryType.COLLISION)
    lock = [model.getJointId(n) for n in model.names[1:] if n not in chain]
    q_lock = pin.neutral(model)
    for jid in lock:  # every locked joint here is a prismatic or bounded revolute one: held at 0
        jm = model.joints[jid]
        assert jm.nq == 1 and q_lock[jm.idx_q] == 0.0, model.names[jid]
    rmodel, rgeom = pin.buildReducedModel(model, gmodel, lock, q_lock)
    assert list(rmodel.names)[1:] == chain, list(rmodel.names)
    assert rmodel.nq == len(chain) == rmodel.nv

    limits = [urdf.joints[j]["limits"] for j in chain]
    assert np.array_equal(rmodel.lowerPositionLimit, [l for l, _ in limits])
    assert np.array_equal(rmodel.upperPositionLimit, [u for _, u in limits])

    # Our objects: <link>/<k> in URDF document order. Pinocchio names them <link>_<k>; check that
    # each one is the k-th <collision> of its link by its kind, dimensions, mesh and placement.
    rdata = rmodel.createData()
    pin.framesForwardKinematics(rmodel, rdata, pin.neutral(rmodel))
    by_name = {go.name: idx for idx, go in enumerate(rgeom.geometryObjects)}
    assert len(by_name) == len(rgeom.geometryObjects) == len(urdf.collisions)
    objects, pin_index, mesh_paths = [], [], []
    for link, k, origin, ugeom in urdf.collisions:
        gi = by_name[f"{link}_{k}"]
        go = rgeom.geometryObjects[gi]
        frame = rmodel.frames[go.parentFrame]
        assert frame.name == link and frame.parentJoint == go.parentJoint, (go.name, frame.name)
        # placement in the joint frame == link frame in the joint frame * URDF origin
        assert np.allclose(se3_matrix(go.placement), se3_matrix(frame.placement) @ origin, atol=1e-12), go.name
        check_geometry(ugeom, go, robots_dir, mesh_paths)
        pin_index.append(gi)
        objects.append((f"{link}/{k}", link, go, ugeom.get("filename")))
    ours_of_pin = {gi: i for i, gi in enumerate(pin_index)}

    # Meshes -> convex hull of their vertices (qhull, "Qt": triangulated facets).
    mesh_vertices = {}
    for oname, link, go, uri in objects:
        if isinstance(go.geometry, coal.BVHModelBase):
            bvh = go.geometry
            mesh_vertices[oname] = int(bvh.num_vertices)
            bvh.buildConvexHull(True, "Qt")
            hull = bvh.convex
            assert isinstance(hull, coal.ConvexBase) and hull.num_points >= 4, oname
            pts = np.asarray(bvh.vertices())
            hp = np.asarray(hull.points())
            # every hull vertex is a mesh vertex, every mesh vertex is inside the hull
            assert all(np.min(np.linalg.norm(pts - v, axis=1)) == 0.0 for v in hp), oname
            go.geometry = hull
            assert inside(go, np.eye(4), pts.mean(axis=0), 0.0)
            for v in pts:
                assert inside(go, np.eye(4), v, 1e-9), oname

    # Pairs.
    n_obj = len(objects)
    olinks = [l for _, l, _, _ in objects]
    if srdf_path:
        disabled = srdf_disabled(srdf_path)
        pairs = [(i, j) for i in range(n_obj) for j in range(i + 1, n_obj)
                 if olinks[i] != olinks[j] and frozenset((olinks[i], olinks[j])) not in disabled]
    else:
        adjacent = {frozenset((jt["parent"], jt["child"])) for jt in urdf.joints.values()}
        pairs = [(i, j) for i in range(n_obj) for j in range(i + 1, n_obj)
                 if olinks[i] != olinks[j] and frozenset((olinks[i], olinks[j])) not in adjacent]

    # Pinocchio's own pair set: every pair on different joints, less the SRDF's.
    rgeom.addAllCollisionPairs()
    if srdf_path:
        pin.removeCollisionPairs(rmodel, rgeom, srdf_path)
    pin_pairs = {tuple(sorted((ours_of_pin[cp.first], ours_of_pin[cp.second]))) for cp in rgeom.collisionPairs}
    assert len(pin_pairs) == len(rgeom.collisionPairs)
    ours = set(pairs)
    same_joint = lambda i, j: objects[i][2].parentJoint == objects[j][2].parentJoint
    if srdf_path:
        # ours = Pinocchio's + the pairs on different links rigidly attached to one joint
        # (Pinocchio's addAllCollisionPairs skips pairs that share a parent joint).
        assert pin_pairs <= ours
        extra = sorted(ours - pin_pairs)
        assert all(same_joint(i, j) for i, j in extra)
    else:
        # no SRDF: ours = Pinocchio's less the pairs of links joined by one joint
        assert ours <= pin_pairs
        assert all(frozenset((olinks[i], olinks[j])) in adjacent for i, j in pin_pairs - ours)
        extra = sorted(p for p in ours if same_joint(*p))
    print(f"{name}: {n_obj} objects, {len(pairs)} pairs; Pinocchio after removal: {len(pin_pairs)}"
          f"; ours not in Pinocchio's: {[(objects[i][0], objects[j][0]) for i, j in sorted(ours - pin_pairs)]}",
          file=sys.stderr)

    rgeom.removeAllCollisionPairs()
    for i, j in pairs:
        rgeom.addCollisionPair(pin.CollisionPair(pin_index[i], pin_index[j]))
    assert len(rgeom.collisionPairs) == len(pairs)
    swapped = []
    for p, (i, j) in enumerate(pairs):
        cp = rgeom.collisionPairs[p]
        assert {cp.first, cp.second} == {pin_index[i], pin_index[j]}
        swapped.append(cp.first != pin_index[i])

    rdata = rmodel.createData()
    gdata = pin.GeometryData(rgeom)  # after the hulls: its functors hold the geometries
    for req in gdata.distanceRequests:
        assert req.enable_signed_distance
    # The same with coal's tolerances tightened, to measure how far the recorded values (coal's
    # defaults, as Pinocchio uses them) are from converged ones.
    gdata_tight = pin.GeometryData(rgeom)
    for req in gdata_tight.distanceRequests:
        req.gjk_convergence_criterion = coal.GJKConvergenceCriterion.DualityGap
        req.gjk_convergence_criterion_type = coal.GJKConvergenceCriterionType.Absolute
        req.gjk_tolerance, req.epa_tolerance = 1e-9, 1e-8
        req.gjk_max_iterations, req.epa_max_iterations = 1000, 1000
    # (GJK: absolute duality gap 1e-9; EPA: 1e-8, below which it fails on the cylinders)

    supports = [support(go) for _, _, go, _ in objects]
    dirs = sphere_directions(args.directions)
    check = {"point_err": 0.0, "support_min": math.inf, "separation_gap": 0.0, "tight_diff": 0.0, "tight_failed": 0, "tight_disagree": 0,
             "tight_disagree_max": 0.0,
             "depth_excess": -math.inf, "negative_checked": 0}
    seed = SEED_BASE + r
    qs = configurations(seed, limits, args.configurations)
    dist = np.empty((args.configurations, len(pairs)), dtype=np.float64)
    witness = []
    n_fk_checks = 20
    for c in range(args.configurations):
        q = qs[c]
        pin.computeDistances(rmodel, rdata, rgeom, gdata, q)
        pin.computeDistances(rmodel, rdata, rgeom, gdata_tight, q)
        poses = [se3_matrix(gdata.oMg[gi]) for gi in pin_index]
        for p, (i, j) in enumerate(pairs):
            res = gdata.distanceResults[p]
            d = dist[c, p] = res.min_distance
            # Certificate along coal's normal n (from the first object to the second): p2 - p1 = d n,
            # p1 is the first object's extreme point along n, p2 the second's along -n. With the
            # points inside their objects (checked below for the witness configurations), this
            # proves d when d > 0; when d < 0, |d| is the overlap along n, and no sampled direction
            # may show a smaller overlap (the penetration depth is the least one over directions).
            n = np.asarray(res.normal, dtype=float)
            p1, p2 = np.asarray(res.getNearestPoint1()), np.asarray(res.getNearestPoint2())
            if swapped[p]:
                n, p1, p2 = -n, p2, p1
            u = np.stack([n, -n])
            hi = world_support(supports[i], poses[i], u[:1])[0]
            hj = world_support(supports[j], poses[j], u[1:])[0]
            e1, e2 = hi - n @ p1, hj + n @ p2  # >= 0 when the points lie in their objects
            check["point_err"] = max(check["point_err"], float(np.linalg.norm(p2 - p1 - d * n)))
            check["support_min"] = min(check["support_min"], e1, e2)
            if d > 0:  # the plane normal to n proves a distance of at least d - e1 - e2
                check["separation_gap"] = max(check["separation_gap"], e1 + e2)
            res_t = gdata_tight.distanceResults[p]
            if abs(res_t.min_distance) > 1e300:  # EPA gave up at the tight tolerance
                check["tight_failed"] += 1
            elif abs(d - res_t.min_distance) > 1e-5:  # counted, not asserted: see the README
                check["tight_disagree"] += 1
                check["tight_disagree_max"] = max(check["tight_disagree_max"], abs(d - res_t.min_distance))
            else:
                check["tight_diff"] = max(check["tight_diff"], abs(d - res_t.min_distance))
            if d < 0:
                overlap = world_support(supports[i], poses[i], dirs) + world_support(supports[j], poses[j], -dirs)
                check["depth_excess"] = max(check["depth_excess"], -d - float(overlap.min()))
                check["negative_checked"] += 1
        if c < n_fk_checks:
            # Pinocchio's world pose of every object == the chain rebuilt from the URDF here
            poses = urdf.link_poses(dict(zip(chain, q)))
            for (oname, link, go, uri), gi, (l2, k, origin, _) in zip(objects, pin_index, urdf.collisions):
                assert np.allclose(se3_matrix(gdata.oMg[gi]), poses[link] @ origin, atol=1e-12), oname
        if c < args.witness:
            for p, (i, j) in enumerate(pairs):
                res = gdata.distanceResults[p]
                p1, p2 = np.array(res.getNearestPoint1()), np.array(res.getNearestPoint2())
                if swapped[p]:
                    p1, p2 = p2, p1
                d = float(res.min_distance)
                assert abs(np.linalg.norm(p1 - p2) - abs(d)) <= 1e-9, (c, p, d, p1, p2)
                # in the world frame: each point lies in its own object
                assert inside(objects[i][2], se3_matrix(gdata.oMg[pin_index[i]]), p1, 1e-6), (c, p, 1)
                assert inside(objects[j][2], se3_matrix(gdata.oMg[pin_index[j]]), p2, 1e-6), (c, p, 2)
                witness.append({"config": c, "pair": p, "distance": d,
                                "p1": [float(v) for v in p1], "p2": [float(v) for v in p2]})
    assert np.all(np.isfinite(dist))
    # coal's tolerances are 1e-6 (GJK and EPA); allow a few times that
    assert check["point_err"] <= 1e-9 and check["support_min"] >= -1e-9, check
    assert check["separation_gap"] <= 1e-3 and check["depth_excess"] <= 1e-5, check

    out = {
        "robot": name,
        "urdf": urdf_file,
        "srdf": os.path.basename(srdf_path) if srdf_path else None,
        "coal_version": version("coal"),
        "pin_version": version("pin"),
        "seed": seed,
        "configurations": args.configurations,
        "joints": chain,
        "limits": [[lo, hi] for lo, hi in limits],
        "objects": [object_entry(n, l, go, uri) for n, l, go, uri in objects],
        "pairs": [[i, j] for i, j in pairs],
        "distances_file": f"{name}_distances.f32",
        "first_q": [float(v) for v in qs[0]],
        "witness_configurations": args.witness,
        "witness": witness,
    }
    stats = {"objects": n_obj, "pairs": len(pairs), "min": float(dist.min()), "max": float(dist.max()),
             "negative": int((dist < 0).sum()), "negative_configs": int((dist < 0).any(axis=1).sum()),
             "pinocchio_pairs": len(pin_pairs), "certificate": check,
             "extra": [(objects[i][0], objects[j][0]) for i, j in sorted(ours - pin_pairs)],
             "mesh_vertices": mesh_vertices,
             "hull_vertices": {n: int(go.geometry.num_points) for n, l, go, u in objects if isinstance(go.geometry, coal.ConvexBase)},
             "pair_min": {f"{objects[i][0]}~{objects[j][0]}": float(dist[:, p].min()) for p, (i, j) in enumerate(pairs)}}
    return out, dist, stats


def dump(obj):
    # one witness record a line; otherwise compact
    head = {k: v for k, v in obj.items() if k != "witness"}
    text = json.dumps(head, indent=1)
    assert text.endswith("\n}")
    lines = [json.dumps(w, separators=(",", ":")) for w in obj["witness"]]
    return text[:-2] + ',\n "witness": [\n' + ",\n".join(lines) + "\n ]\n}\n"


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", default="/work/shared/robots", help="the robots dir (URDFs, package dirs)")
    ap.add_argument("--out", default=os.path.join(here, "..", "..", "tests", "data", "collision"))
    ap.add_argument("--configurations", type=int, default=10000)
    ap.add_argument("--witness", type=int, default=200, help="configurations with witness points")
    ap.add_argument("--directions", type=int, default=500,
                    help="sampled directions that check each penetration depth")
    ap.add_argument("--robot", action="append", help="only these robots (default all)")
    ap.add_argument("--max-json-bytes", type=int, default=1_500_000,
                    help="above it, witness points for the first 50 configurations only")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    summary = {}
    for spec in ROBOTS:
        if args.robot and spec[0] not in args.robot:
            continue
        out, dist, stats = run_robot(spec, args)
        text = dump(out)
        if len(text.encode()) > args.max_json_bytes and args.witness > 50:
            keep = [w for w in out["witness"] if w["config"] < 50]
            out["witness"], out["witness_configurations"] = keep, 50
            text = dump(out)
        name = spec[0]
        with open(os.path.join(args.out, f"{name}.json"), "w") as f:
            f.write(text)
        dist.astype("<f4").tofile(os.path.join(args.out, f"{name}_distances.f32"))
        stats["witness_configurations"] = out["witness_configurations"]
        stats["json_bytes"] = len(text.encode())
        summary[name] = stats
        print(json.dumps({name: stats}, indent=1))
    return summary


if __name__ == "__main__":
    main()
