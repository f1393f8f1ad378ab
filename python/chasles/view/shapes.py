"""What the view draws for each link: the URDF's <visual> elements, or its <collision> ones where a
link has no visual that can be read, each as a mesh fixed to one link of the model's chain.

chasles's own forward kinematics (Model.link_poses) places the chain's links; a link off the chain
(a finger, a tool frame past the tip) rides rigidly on the nearest chain link above it with the
joints between at zero, as the collision model attaches it (docs/geometry.md).
"""
from __future__ import annotations

import dataclasses
import os
import xml.etree.ElementTree as ET
from typing import Optional, Sequence

import numpy as np

# Colours (RGB 0-255). The arm's when its files give none: an orange no background, ghost or arrow
# uses, so that a screenshot tells the arm apart by hue.
ARM_COLOR = (235, 120, 20)


@dataclasses.dataclass
class Part:
    """One mesh on one chain link: T_lp places it in the link's frame."""

    link: str  # the chain link (Model.link_names) it rides on
    T_lp: np.ndarray  # (4, 4)
    vertices: np.ndarray  # (V, 3) float32, in the part's frame, scaled
    faces: np.ndarray  # (F, 3) uint32
    color: tuple  # RGB 0-255, used when glb is None
    glb: Optional[bytes]  # the file's own materials, for a visual that has them (Collada, glTF)
    source: str  # "<link> visual 0 (link0.dae)", for messages


def rpy_matrix(rpy: Sequence[float]) -> np.ndarray:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _floats(text: Optional[str], n: int, default: Sequence[float], where: str) -> np.ndarray:
    if text is None:
        return np.array(default, dtype=float)
    values = np.array([float(v) for v in text.split()])
    if values.shape != (n,) or not np.all(np.isfinite(values)):
        raise ValueError(f"{where}: '{text}' is not {n} finite numbers")
    return values


def origin_matrix(element: Optional[ET.Element], where: str) -> np.ndarray:
    T = np.eye(4)
    if element is not None:
        T[:3, :3] = rpy_matrix(_floats(element.get("rpy"), 3, (0, 0, 0), where + " <origin rpy>"))
        T[:3, 3] = _floats(element.get("xyz"), 3, (0, 0, 0), where + " <origin xyz>")
    return T


def resolve_uri(uri: str, base_dir: str, package_dirs: Sequence[str]) -> str:
    """A mesh's filename as the C++ loader resolves it (core/geometry/collision_model.cpp):
    package://NAME/rest in each package dir in turn, file:// or a path relative to the URDF's
    folder. Raises FileNotFoundError saying where it looked."""
    if uri.startswith("package://"):
        rest = uri[len("package://"):]
        for folder in package_dirs:
            candidate = os.path.join(folder, rest)
            if os.path.isfile(candidate):
                return candidate
        package = rest.split("/", 1)[0]
        if not any(os.path.isdir(os.path.join(folder, package)) for folder in package_dirs):
            dirs = ", ".join(f"'{d}'" for d in package_dirs) or "none given"
            raise FileNotFoundError(f"package '{package}' is in none of the package dirs ({dirs})")
        raise FileNotFoundError(f"no such file in package '{package}'")
    path = uri[len("file://"):] if uri.startswith("file://") else uri
    if not os.path.isabs(path):
        path = os.path.join(base_dir, path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"no such file '{path}'")
    return path


def _geometry(element: ET.Element, base_dir: str, package_dirs: Sequence[str], where: str):
    """(vertices, faces, glb or None) of one <visual> or <collision>'s <geometry>."""
    import trimesh

    geometry = element.find("geometry")
    shape = None if geometry is None else next(iter(geometry), None)
    if shape is None:
        raise ValueError("<geometry> holds no shape")
    kind = shape.tag
    if kind == "box":
        mesh = trimesh.creation.box(extents=_floats(shape.get("size"), 3, None, where + " <box size>"))
    elif kind == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=float(shape.get("radius")))
    elif kind == "cylinder":  # URDF's and trimesh's both along z, centred
        mesh = trimesh.creation.cylinder(radius=float(shape.get("radius")), height=float(shape.get("length")))
    elif kind.endswith("capsule"):  # Drake's <drake:capsule> (namespaced) and plain <capsule>
        mesh = trimesh.creation.capsule(radius=float(shape.get("radius")), height=float(shape.get("length")))
    elif kind == "mesh":
        uri = shape.get("filename")
        if not uri:
            raise ValueError("<mesh> has no filename")
        path = resolve_uri(uri, base_dir, package_dirs)
        scale = shape.get("scale")
        scale = np.ones(3) if scale is None else np.broadcast_to(
            [float(v) for v in scale.split()], (3,)).astype(float)
        scene = trimesh.load(path, force="scene")
        if not scene.geometry:
            raise ValueError(f"mesh '{path}' holds no triangles")
        scene.apply_transform(np.diag([*scale, 1.0]))
        mesh = scene.to_geometry()
        glb = None
        # Files with materials of their own keep them (the Panda's .dae are coloured and textured);
        # STL and OBJ without materials are drawn in the URDF's colour.
        if os.path.splitext(path)[1].lower() in (".dae", ".glb", ".gltf"):
            glb = scene.export(file_type="glb")
        return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32), glb
    else:
        raise ValueError(f"<{kind}> is no shape the view draws (box, sphere, cylinder, capsule, mesh)")
    return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32), None


def _material_colors(robot: ET.Element) -> dict:
    colors = {}
    for material in robot.findall("material"):
        color = material.find("color")
        if material.get("name") and color is not None and color.get("rgba"):
            colors[material.get("name")] = color.get("rgba")
    return colors


def _color(visual: ET.Element, named: dict) -> tuple:
    material = visual.find("material")
    if material is None:
        return ARM_COLOR
    color = material.find("color")
    rgba = color.get("rgba") if color is not None else named.get(material.get("name", ""))
    try:
        values = [float(v) for v in rgba.split()]
        return tuple(int(round(255 * min(max(v, 0.0), 1.0))) for v in values[:3])
    except (AttributeError, ValueError, IndexError):
        return ARM_COLOR


def anchors(robot: ET.Element, chain_links: Sequence[str]) -> dict:
    """{link: (chain link, T_chain_link)} for every link of the URDF: the nearest chain link at or
    above it (or the chain's base for a link in no chain link's subtree), with every joint at zero."""
    parent_of = {}
    for joint in robot.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is not None and child is not None:
            parent_of[child.get("link")] = (parent.get("link"), origin_matrix(joint.find("origin"), f"joint '{joint.get('name')}'"))
    T_root = {}

    def root_pose(link: str, depth: int = 0) -> np.ndarray:
        if link not in T_root:
            if link not in parent_of or depth > len(parent_of):
                T_root[link] = np.eye(4)
            else:
                parent, T_pc = parent_of[link]
                T_root[link] = root_pose(parent, depth + 1) @ T_pc
        return T_root[link]

    chain = set(chain_links)
    result = {}
    for element in robot.findall("link"):
        link, anchor = element.get("name"), element.get("name")
        seen = 0
        while anchor not in chain and anchor in parent_of and seen <= len(parent_of):
            anchor, seen = parent_of[anchor][0], seen + 1
        if anchor not in chain:
            anchor = chain_links[0]
        result[link] = (anchor, np.linalg.inv(root_pose(anchor)) @ root_pose(link))
    return result


def load_parts(urdf_path: str, chain_links: Sequence[str], package_dirs: Sequence[str]):
    """(parts, notes): every link's visuals; a link none of whose visuals can be read (or that has
    none) its collisions instead. notes says, once per link, what could not be drawn and why."""
    robot = ET.parse(urdf_path).getroot()
    base_dir = os.path.dirname(os.path.abspath(urdf_path))
    named = _material_colors(robot)
    attach = anchors(robot, chain_links)
    parts, notes = [], []
    for element in robot.findall("link"):
        link = element.get("name")
        anchor, T_al = attach[link]
        drawn, problems = [], []
        for tag in ("visual", "collision"):
            for k, item in enumerate(element.findall(tag)):
                where = f"link '{link}' <{tag}> {k}"
                try:
                    vertices, faces, glb = _geometry(item, base_dir, package_dirs, where)
                    T_lp = T_al @ origin_matrix(item.find("origin"), where)
                except Exception as e:  # a bad file of any kind: said, and the next shape tried
                    problems.append(f"{where}: {e}")
                    continue
                color = _color(item, named) if tag == "visual" else ARM_COLOR
                drawn.append(Part(anchor, T_lp, vertices, faces, color, glb if tag == "visual" else None, where))
            if drawn:
                break
            if tag == "visual" and problems:
                problems[-1] += "; drawing its collision shapes"
        notes.extend(problems)
        if problems and not drawn:
            notes.append(f"link '{link}': nothing drawn")
        parts.extend(drawn)
    return parts, notes
