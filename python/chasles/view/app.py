"""The live view: each arm as its latest state puts it (chasles's robot_state_t or Drake's iiwa or
Panda status), the reference of the latest controller_status_t as a ghost, the estimated and the
true contact force as arrows, the target, the stiffness frame under Cartesian impedance, the scene
and its closest pair, and the controller's state in the panel; served by viser (docs/view.md says
why viser).

One thread hears the bus and draws, for every arm. It wakes once a frame and takes what LCM queued
meanwhile; each handler keeps only its channel's newest message, as bytes: at 1 kHz decoding every
state would cost more than drawing, and a view that queued would fall behind. At most `rate` times
a second the newest ones are decoded, checked and drawn.
"""
from __future__ import annotations

import math
import sys
import threading
import time
from typing import Callable, Optional, Sequence

import numpy as np

from chasles._command_checks import LAWS, rotation_from_quaternion
from chasles._core import ArgumentError, decode_scene
from chasles._messages import STATES, Status
from chasles.lcmtypes import (arm_target_t, control_mode_t, controller_status_t, lcmt_iiwa_status,
                              lcmt_panda_status, robot_state_t, sim_truth_t, tip_setpoint_t)

from .shapes import Part

GHOST_COLOR = (40, 110, 255)
ESTIMATE_COLOR = (210, 0, 200)
TRUTH_COLOR = (0, 170, 60)
OBSTACLE_COLOR = (120, 120, 120)  # the scene's keep-out objects, translucent
PLANE_COLOR = (150, 150, 150)  # a safety plane's patch, more translucent
WORKSPACE_COLOR = (70, 70, 70)  # a workspace box's edges
CLEARANCE_COLOR = (245, 200, 0)  # the closest pair's gap, yellow
SLOWING_COLOR = (230, 20, 20)  # the same while that pair is the one slowing the motion
CAMERA_FOV_DEG = 50.0  # vertical field of view of the view's camera
GHOST_THRESHOLD = 1e-3  # rad or m: a reference nearer than this to q hides inside the arm anyway
TRUTH_STALE_S = 0.5  # a TRUTH channel silent this long no longer draws its arrows
SILENT_S = 1.0  # a channel heard before and silent this long is said so in the panel
PANEL_PERIOD_S = 0.1  # the panel's text is rewritten at most this often (the browser lays it out)
QUEUE_CAPACITY = 2000  # messages LCM keeps per channel between two draws (1 s at 1 kHz)
# A status this long after a target (or tip setpoint) has had time to answer it: the controller
# takes a goal at its next tick and reports at ~100 Hz. Until then the goal is drawn whatever the
# status says; after, only while the status says the arm runs toward it.
GOAL_ANSWER_S = 0.1
QUATERNION_TOLERANCE = 1e-3  # a norm further from 1 is refused, as the controller refuses it
PLANE_SIDE = 1.0  # m: a safety plane is drawn as a square this wide around its point nearest the base
LAW_NAMES = {value: name for name, value in LAWS.items()}
TARGET_MODES = {arm_target_t.HOLD: "HOLD", arm_target_t.JOINT: "JOINT", arm_target_t.CARTESIAN: "CARTESIAN"}

# The arm driver's status each protocol reads (docs/protocols.md): its type, its default channel
# (chasles's is PREFIX STATE; Drake's channels take no prefix, as the controller's), the field that
# places the arm and the field drawn as the ghost while no controller status is heard.
PROTOCOLS = {
    "chasles": (robot_state_t, "STATE", "position", None),
    "drake-iiwa": (lcmt_iiwa_status, "IIWA_STATUS", "joint_position_measured", "joint_position_commanded"),
    "drake-panda": (lcmt_panda_status, "PANDA_STATUS", "joint_position", "joint_position_desired"),
}


def quaternion_wxyz(R) -> tuple:
    """The unit quaternion (w, x, y, z), w >= 0, of a rotation matrix, by Shepperd's method: from
    the largest of 1 + trace and 1 + 2 R_ii - trace, so that no branch divides by a small number.
    In plain floats: for one 3×3 it is ten times quicker than numpy's calls (14 against 147 µs for
    the Panda's ten links)."""
    (a, b, c), (d, e, f), (g, h, i) = (tuple(map(float, row)) for row in R)
    t = a + e + i
    if t >= a and t >= e and t >= i:
        r = 2 * math.sqrt(1 + t)
        q = (r / 4, (h - f) / r, (c - g) / r, (d - b) / r)
    elif a >= e and a >= i:
        r = 2 * math.sqrt(1 + 2 * a - t)
        q = ((h - f) / r, r / 4, (b + d) / r, (c + g) / r)
    elif e >= i:
        r = 2 * math.sqrt(1 + 2 * e - t)
        q = ((c - g) / r, (b + d) / r, r / 4, (f + h) / r)
    else:
        r = 2 * math.sqrt(1 + 2 * i - t)
        q = ((d - b) / r, (c + g) / r, (f + h) / r, r / 4)
    n = math.sqrt(sum(v * v for v in q)) * (1.0 if q[0] >= 0 else -1.0)
    return tuple(v / n for v in q)


def default_camera(points) -> tuple[np.ndarray, np.ndarray]:
    """(eye, target): the points (the arms' link origins at q = 0, view frame) in view, from the
    front right and above."""
    points = np.asarray(points, float).reshape(-1, 3)
    low, high = points.min(axis=0), points.max(axis=0)
    target = (low + high) / 2
    reach = max(float(np.linalg.norm(high - low)), 0.3)
    direction = np.array([1.0, 0.75, 0.45])
    return target + 1.6 * reach * direction / np.linalg.norm(direction), target


def setup_scene(server, camera: tuple) -> None:
    """What every arm shares: the up direction, the lights, the camera and the floor's grid."""
    scene = server.scene
    scene.set_up_direction("+z")
    # Shadows cost more than the rest of a frame in a software renderer (2.5 against ~8 fps in
    # headless Chromium's SwiftShader, 960×720) and say little about where the arm is.
    scene.configure_default_lights(cast_shadow=False)
    scene.configure_environment_map(None)
    eye, target = camera
    server.initial_camera.position = tuple(float(v) for v in eye)
    server.initial_camera.look_at = tuple(float(v) for v in target)
    server.initial_camera.up = (0.0, 0.0, 1.0)
    server.initial_camera.fov = math.radians(CAMERA_FOV_DEG)
    scene.add_grid("/grid", width=2.0, height=2.0, cell_size=0.1, section_size=0.5)


class Latest:
    """The newest message of one channel, as bytes, and how many came."""

    def __init__(self, clock: Callable[[], float]):
        self.clock = clock
        self.data: Optional[bytes] = None
        self.count = 0
        self.taken = 0  # count when data was last drawn
        self.when = 0.0  # the clock's time of the newest

    def __call__(self, channel: str, data: bytes, when: Optional[float] = None) -> None:
        self.data, self.count = data, self.count + 1
        self.when = self.clock() if when is None else when

    def fresh(self) -> Optional[bytes]:
        """The newest bytes if they came since the last call, else None."""
        if self.count == self.taken:
            return None
        self.taken = self.count
        return self.data


def check_joints(channel: str, values: dict, nq: int) -> Optional[str]:
    """Why a message's joint arrays cannot be drawn on this model, or None."""
    for name, array in values.items():
        if len(array) != nq:
            return f"{channel}: {name} has {len(array)} entries, the model has {nq} joints: messages skipped"
        bad = np.flatnonzero(~np.isfinite(array))
        if bad.size:
            return f"{channel}: {name}[{bad[0]}] is {array[bad[0]]}: messages like it skipped"
    return None


def pose_problem(position, wxyz) -> Optional[str]:
    """Why a (position, unit quaternion) cannot be a pose, or None."""
    values = np.concatenate([np.asarray(position, float), np.asarray(wxyz, float)])
    if not np.all(np.isfinite(values)):
        return "a pose field is not finite"
    norm = float(np.linalg.norm(wxyz))
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        return f"its quaternion's norm is {norm:.6g}, not 1"
    return None


def transform(position, wxyz) -> np.ndarray:
    T = np.eye(4)
    wxyz = np.asarray(wxyz, float)
    T[:3, :3] = rotation_from_quaternion(wxyz / np.linalg.norm(wxyz))
    T[:3, 3] = position
    return T


def scene_meshes(scene: dict):
    """[(kind, name, vertices, faces, T)] of a scene as read_scene_file or decode_scene give it:
    each object's shape as a mesh, each safety plane's square patch (z along its normal), in the
    base frame; and the workspace boxes' edges as (2, 3) segments."""
    import trimesh

    meshes = []
    for o in scene["objects"]:
        kind, r, h = o["kind"], o["radius"], o["half_length"]
        if kind == "sphere":
            mesh = trimesh.creation.icosphere(subdivisions=3, radius=r)
        elif kind == "box":
            mesh = trimesh.creation.box(extents=2 * np.asarray(o["half_extents"]))
        elif kind == "cylinder":
            mesh = trimesh.creation.cylinder(radius=r, height=2 * h)
        elif kind == "capsule":
            mesh = trimesh.creation.capsule(radius=r, height=2 * h)
        else:  # convex: the hull of the vertices the reader kept (those on the hull)
            mesh = trimesh.convex.convex_hull(np.asarray(o["vertices"]))
        meshes.append(("object", o["name"], mesh.vertices, mesh.faces, np.asarray(o["pose"])))
    half = PLANE_SIDE / 2
    square = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]])
    for p in scene["planes"]:
        n = np.asarray(p["normal"], float)
        # The plane's frame: z its normal, its origin the plane's point nearest the base's origin.
        helper = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
        x = np.cross(helper, n)
        x /= np.linalg.norm(x)
        T = np.eye(4)
        T[:3, :3] = np.stack([x, np.cross(n, x), n], axis=1)
        T[:3, 3] = p["offset"] * n
        meshes.append(("plane", p["name"], square, np.array([[0, 1, 2], [0, 2, 3]]), T))
    edges = []
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    pairs = [(a, b) for a in range(8) for b in range(a + 1, 8) if np.sum(corners[a] != corners[b]) == 1]
    for b in scene["boxes"]:
        T = np.asarray(b["pose"])
        world = corners * np.asarray(b["half_extents"]) @ T[:3, :3].T + T[:3, 3]
        edges.extend(np.stack([world[a], world[c]]) for a, c in pairs)
    return meshes, np.array(edges).reshape(-1, 2, 3)


class View:
    """One arm: its links, ghost, arrows, target, stiffness frame, scene and clearance under its own
    root in the scene tree (posed at `base`, the arm's base frame in the view's), fed by its own
    channels, with its own part of the panel."""

    def __init__(self, server, model, parts: Sequence[Part], notes: Sequence[str], *, name: str = "arm",
                 prefix: str = "CHASLES_", protocol: str = "chasles", state_channel: Optional[str] = None,
                 base: Optional[np.ndarray] = None, scene: Optional[dict] = None, scene_source: str = "",
                 title: Optional[str] = None, rate: float = 30.0, force_scale: float = 0.01,
                 say: Callable[[str], None] = lambda text: print(text, file=sys.stderr, flush=True)):
        self.server, self.model, self.prefix, self.name = server, model, prefix, name
        self.who = "" if title is None else f"arm '{name}': "  # what stderr's lines of several arms start with
        self.protocol = protocol
        self.state_type, default_channel, self.state_field, self.ghost_field = PROTOCOLS[protocol]
        if state_channel is None:
            state_channel = prefix + default_channel if protocol == "chasles" else default_channel
        self.state_channel = state_channel
        self.period, self.force_scale, self.say = 1.0 / rate, force_scale, say
        # The time messages are judged fresh or silent by, s: the wall's; a replay sets the log's.
        self.live, self.clock = True, time.monotonic
        self.state, self.status, self.truth = Latest(self.clock), Latest(self.clock), Latest(self.clock)
        self.target, self.tip_setpoint, self.mode, self.scene_bytes = (Latest(self.clock) for _ in range(4))
        self.caption = ""  # a line of the panel's own, above the rest (the replay's time)
        self.notes: list[str] = []
        self.q: Optional[np.ndarray] = None
        self.state_seq: Optional[int] = None  # chasles's seq, or a Drake status's utime
        self.driver_ghost: Optional[np.ndarray] = None  # a Drake status's commanded position
        self.last_status: Optional[Status] = None
        self.status_when = 0.0  # when the status drawn came
        self.last_truth = None
        # The goal drawn as the target frame: (T_sb, what it is, when it came, "target" or "setpoint").
        self.goal: Optional[tuple] = None
        self.goal_ended = False  # a status answered the goal with the arm no longer running toward it
        self.stiffness_law: Optional[int] = None  # the latest control mode's law
        self.T_tip_stiffness: Optional[np.ndarray] = None  # the latest Cartesian mode's frame c in the tip's
        self.scene_summary, self.scene_problem = "none", ""
        self.draws = 0
        self.rates = (0.0, 0.0)  # states heard and draws, per second, over the last second
        self._rate_mark = (time.monotonic(), 0, 0)
        self._panel_text, self._panel_sent = "", 0.0
        self._posed, self._pointed = {}, {}  # the q each node set, and the points each arrow, last sent
        self._sent: dict = {}  # {node set: {link index: (position, wxyz) last sent}}
        self._scene_handles: list = []
        self._clearance_sent = None  # (points, colour) last sent
        for note in notes:
            self.note(note)
        self._build(parts, base, title)
        if scene is not None:
            self._draw_scene(scene, scene_source)

    # -- the scene --

    def _build(self, parts: Sequence[Part], base: Optional[np.ndarray], title: Optional[str]) -> None:
        scene = self.server.scene
        T = np.eye(4) if base is None else np.asarray(base, float)
        root = f"/{self.name}"
        scene.add_frame(root, show_axes=False, position=tuple(T[:3, 3]), wxyz=quaternion_wxyz(T[:3, :3]))
        # The chain's links nest in the scene tree, each posed in its parent's frame: a revolute
        # joint then changes only its child's orientation and a fixed joint nothing, one message
        # per moving joint a draw rather than two per link (viser's per-assignment cost is ~80 µs).
        self.arm, self.ghost = [], []
        self.ghost_root = scene.add_frame(f"{root}/ghost", show_axes=False, visible=False)
        path = ""
        for link in self.model.link_names:
            path += f"/{link}"
            self.arm.append(scene.add_frame(f"{root}/arm{path}", show_axes=False))
            self.ghost.append(scene.add_frame(f"{root}/ghost{path}", show_axes=False))
            for k, part in enumerate(p for p in parts if p.link == link):
                pose = dict(position=part.T_lp[:3, 3], wxyz=quaternion_wxyz(part.T_lp[:3, :3]))
                if part.glb is not None:
                    scene.add_glb(f"{root}/arm{path}/part{k}", part.glb, **pose)
                else:
                    scene.add_mesh_simple(f"{root}/arm{path}/part{k}", part.vertices, part.faces, color=part.color,
                                          **pose)
                scene.add_mesh_simple(f"{root}/ghost{path}/part{k}", part.vertices, part.faces, color=GHOST_COLOR,
                                      opacity=0.35, cast_shadow=False, receive_shadow=False, **pose)
        arrow = dict(shaft_radius=0.01, head_radius=0.025, head_length=0.05, visible=False)
        self.estimate_arrow = scene.add_arrows(f"{root}/force/estimate", np.zeros((1, 2, 3)), ESTIMATE_COLOR, **arrow)
        self.truth_arrow = scene.add_arrows(f"{root}/force/truth", np.zeros((1, 2, 3)), TRUTH_COLOR, **arrow)
        # The target: RGB axes (x red, y green, z blue); the stiffness frame: shorter, thicker axes
        # with a dark origin, so that the two are told apart where they meet.
        self.target_frame = scene.add_frame(f"{root}/target", axes_length=0.15, axes_radius=0.008, visible=False)
        self.stiffness_frame = scene.add_frame(f"{root}/stiffness", axes_length=0.08, axes_radius=0.01,
                                               origin_radius=0.016, origin_color=(40, 40, 40), visible=False)
        # The gap, from the arm's witness to the other's: a thin rod, an arrow with no head to speak
        # of (a line segment whose points were changed in place was not redrawn in headless Chromium
        # here; an arrow's points and colour are, as the force arrows show).
        self.clearance_rod = scene.add_arrows(f"{root}/clearance", np.zeros((1, 2, 3)), CLEARANCE_COLOR,
                                               shaft_radius=0.01, head_radius=0.01, head_length=1e-4,
                                               visible=False)
        if title is None:
            self.panel = self.server.gui.add_markdown("waiting for the arm's state")
        else:
            with self.server.gui.add_folder(title):
                self.panel = self.server.gui.add_markdown("waiting for the arm's state")
        self._pose(self.arm, np.zeros(self.model.nq))

    def _draw_scene(self, scene: dict, source: str) -> None:
        """Replaces the scene drawn: obstacles translucent grey, each plane a translucent square
        with its normal, each workspace box its edges."""
        for handle in self._scene_handles:
            handle.remove()
        self._scene_handles = []
        meshes, edges = scene_meshes(scene)
        add, root = self.server.scene, f"/{self.name}/scene"
        for k, (kind, name, vertices, faces, T) in enumerate(meshes):
            pose = dict(position=tuple(T[:3, 3]), wxyz=quaternion_wxyz(T[:3, :3]))
            if kind == "object":
                self._scene_handles.append(add.add_mesh_simple(
                    f"{root}/object{k}", np.asarray(vertices, np.float32), np.asarray(faces, np.uint32),
                    color=OBSTACLE_COLOR, opacity=0.5, cast_shadow=False, receive_shadow=False, **pose))
            else:
                self._scene_handles.append(add.add_mesh_simple(
                    f"{root}/plane{k}", np.asarray(vertices, np.float32), np.asarray(faces, np.uint32),
                    color=PLANE_COLOR, opacity=0.3, side="double", cast_shadow=False, receive_shadow=False, **pose))
                normal = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 0.1]]])  # 0.1 m along the normal
                self._scene_handles.append(add.add_arrows(f"{root}/plane{k}/normal", normal, WORKSPACE_COLOR,
                                                          shaft_radius=0.004, head_radius=0.01, head_length=0.02,
                                                          **pose))
        if len(edges):
            self._scene_handles.append(add.add_line_segments(f"{root}/workspace", edges, WORKSPACE_COLOR,
                                                             thickness=0.004))
        counts = [(len(scene["objects"]), "object"), (len(scene["planes"]), "plane"), (len(scene["boxes"]), "workspace box")]
        self.scene_summary = ", ".join(f"{n} {word}{'' if n == 1 else 'es' if word.endswith('x') else 's'}"
                                       for n, word in counts) + f" ({source})"
        self.scene_problem = ""

    def _pose(self, nodes: list, q: np.ndarray) -> None:
        """Poses nested link frames at q: each link in its parent's frame, T_{i-1,i} =
        T_{s,i-1}^-1 T_{s,i} of chasles's link_poses, sending only what changed."""
        # A status repeats its reference while holding, and a plant its q at rest: nothing to send.
        if np.array_equal(self._posed.get(id(nodes)), q):
            return
        self._posed[id(nodes)] = np.array(q)
        T = self.model.link_poses(q)
        R, p = T[:, :3, :3], T[:, :3, 3]
        R_rel = np.concatenate([R[:1], np.einsum("kji,kjl->kil", R[:-1], R[1:])])
        p_rel = np.concatenate([p[:1], np.einsum("kji,kj->ki", R[:-1], p[1:] - p[:-1])])
        sent = self._sent.setdefault(id(nodes), {})
        for i, node in enumerate(nodes):
            position, wxyz = tuple(p_rel[i].tolist()), quaternion_wxyz(R_rel[i])
            last_position, last_wxyz = sent.get(i, (None, None))
            # Differences of 1e-12 are the rounding of the product above, not motion.
            if last_position is None or max(abs(x - y) for x, y in zip(position, last_position)) > 1e-12:
                node.position = position
                last_position = position
            if last_wxyz is None or max(abs(x - y) for x, y in zip(wxyz, last_wxyz)) > 1e-12:
                node.wxyz = wxyz
                last_wxyz = wxyz
            sent[i] = (last_position, last_wxyz)

    def _place(self, handle, T: np.ndarray) -> None:
        """Poses a frame at T (the arm's base frame), sending only what changed."""
        position, wxyz = tuple(T[:3, 3].tolist()), quaternion_wxyz(T[:3, :3])
        if self._pointed.get(id(handle)) != (position, wxyz):
            handle.position, handle.wxyz = position, wxyz
            self._pointed[id(handle)] = (position, wxyz)
        self._show(handle, True)

    @staticmethod
    def _show(handle, visible: bool) -> None:
        if handle.visible != visible:  # viser sends every assignment; most draws change nothing here
            handle.visible = visible

    def _arrows(self, handle, points: Sequence, forces: Sequence) -> None:
        """Arrows ending at each point, along the force on the arm there (a push points into it),
        force_scale m per N; hidden when there are none."""
        if len(points) == 0:
            self._show(handle, False)
            return
        p = np.asarray(points, float).reshape(-1, 3)
        f = np.asarray(forces, float).reshape(-1, 3)
        points = np.stack([p - self.force_scale * f, p], axis=1)
        if not np.array_equal(self._pointed.get(id(handle)), points):
            handle.points = points
            self._pointed[id(handle)] = points
        self._show(handle, True)

    # -- the bus --

    def note(self, text: str) -> None:
        """Says a problem once: on stderr and in the panel."""
        if text not in self.notes:
            self.notes.append(text)
            self.say(f"chasles view: {self.who}{text}")

    def handlers(self) -> dict:
        """{channel: the handler that keeps its newest bytes}."""
        p = self.prefix
        return {self.state_channel: self.state, p + "STATUS": self.status, p + "TRUTH": self.truth,
                p + "TARGET": self.target, p + "TIP_SETPOINT": self.tip_setpoint, p + "MODE": self.mode,
                p + "SCENE": self.scene_bytes}

    def _decode(self, kind, data: bytes, channel: str):
        try:
            return kind.decode(data)
        except Exception as e:  # another type on the channel, or bytes cut short
            self.note(f"{channel}: a message that is no {kind.__name__} ({e or type(e).__name__}): skipped")
            return None

    def _take(self) -> bool:
        """Decodes and checks the newest messages; True when there is something new to draw."""
        return any([self._take_state(), self._take_status(), self._take_truth(), self._take_goal(),
                    self._take_mode(), self._take_scene()])

    def _take_state(self) -> bool:
        data = self.state.fresh()
        m = None if data is None else self._decode(self.state_type, data, self.state_channel)
        if m is None:
            return False
        arrays = {self.state_field: np.array(getattr(m, self.state_field), float)}
        if self.ghost_field is not None:  # a Drake status: its commanded positions, checked as the controller does
            arrays[self.ghost_field] = np.array(getattr(m, self.ghost_field), float)
        problem = check_joints(self.state_channel, arrays, self.model.nq)
        if problem:
            self.note(problem)
            return False
        self.q = arrays[self.state_field]
        self.state_seq = m.seq if self.protocol == "chasles" else m.utime
        if self.ghost_field is not None:
            self.driver_ghost = arrays[self.ghost_field]
        return True

    def _take_status(self) -> bool:
        data = self.status.fresh()
        m = None if data is None else self._decode(controller_status_t, data, self.prefix + "STATUS")
        if m is None:
            return False
        s = Status.from_message(m)
        problem = check_joints(self.prefix + "STATUS", {"q": s.q, "q_desired": s.q_desired}, self.model.nq)
        drawn = (s.tip_wrench_ext, s.contact_point, s.contact_force, s.tip_position, s.clearance_points,
                 [s.clearance_distance])
        if not problem and not all(np.all(np.isfinite(v)) for v in drawn):
            problem = f"{self.prefix}STATUS: a contact or clearance field is not finite: messages like it skipped"
        if problem:
            self.note(problem)
            return False
        self.last_status, self.status_when = s, self.status.when
        if self.state.count == 0:  # a controller heard before its arm: its q
            self.q = s.q
        return True

    def _take_truth(self) -> bool:
        data = self.truth.fresh()
        m = None if data is None else self._decode(sim_truth_t, data, self.prefix + "TRUTH")
        if m is None:
            return False
        values = [m.tip_wrench_ext, *m.contact_point, *m.contact_force]
        if not all(np.all(np.isfinite(v)) for v in values):
            self.note(f"{self.prefix}TRUTH: a contact field is not finite: messages like it skipped")
            return False
        self.last_truth = m
        return True

    def _take_goal(self) -> bool:
        """The newest target (arm_target_t) or tip setpoint (tip_setpoint_t): the pose it asks of
        the tip, or None for HOLD."""
        changed = False
        channel = self.prefix + "TARGET"
        data = self.target.fresh()
        m = None if data is None else self._decode(arm_target_t, data, channel)
        if m is not None:
            problem, T = None, None
            if m.mode == arm_target_t.JOINT:
                q = np.array(m.joint_position, float)
                problem = check_joints(channel, {"joint_position": q}, self.model.nq)
                T = None if problem else self.model.fk(q)
            elif m.mode == arm_target_t.CARTESIAN:
                problem = pose_problem(m.tip_position, m.tip_quaternion)
                if problem:
                    problem = f"{channel}: {problem}: messages like it skipped"
                else:
                    T = transform(m.tip_position, m.tip_quaternion)
            elif m.mode != arm_target_t.HOLD:
                problem = f"{channel}: mode {m.mode} is none of HOLD 0, JOINT 1, CARTESIAN 2: messages like it skipped"
            if problem:
                self.note(problem)
            else:
                self.goal, self.goal_ended, changed = (T, f"target {TARGET_MODES[m.mode]}", self.target.when, "target"), False, True
        channel = self.prefix + "TIP_SETPOINT"
        data = self.tip_setpoint.fresh()
        m = None if data is None else self._decode(tip_setpoint_t, data, channel)
        if m is not None:
            problem = pose_problem(m.position, m.quaternion)
            if problem:
                self.note(f"{channel}: {problem}: messages like it skipped")
            elif self.goal is None or self.tip_setpoint.when >= self.goal[2]:
                self.goal = (transform(m.position, m.quaternion), "tip setpoint", self.tip_setpoint.when, "setpoint")
                self.goal_ended, changed = False, True
        return changed

    def _take_mode(self) -> bool:
        channel = self.prefix + "MODE"
        data = self.mode.fresh()
        m = None if data is None else self._decode(control_mode_t, data, channel)
        if m is None:
            return False
        if m.law == control_mode_t.CARTESIAN_IMPEDANCE:
            problem = pose_problem(m.stiffness_frame_position, m.stiffness_frame_quaternion)
            if problem:
                self.note(f"{channel}: the stiffness frame: {problem}: messages like it skipped")
                return False
            self.T_tip_stiffness = transform(m.stiffness_frame_position, m.stiffness_frame_quaternion)
        self.stiffness_law = m.law
        return True

    def _take_scene(self) -> bool:
        channel = self.prefix + "SCENE"
        data = self.scene_bytes.fresh()
        if data is None:
            return False
        try:  # the controller's own checks and reader (chasles._core.decode_scene)
            scene = decode_scene(data)
        except ArgumentError as e:
            self.scene_problem = f"{channel}: refused ({e}); the scene drawn is kept"
            self.note(self.scene_problem)
            return True
        self._draw_scene(scene, channel)
        return True

    # -- drawing --

    def goal_shown(self) -> bool:
        """(Latches goal_ended.) Whether the target frame is drawn: a goal other than HOLD, from when it is heard until a
        status that came GOAL_ANSWER_S or more after it says the arm no longer runs toward it (not
        RUNNING for a target; not streaming for a tip setpoint): the move ended (HOLDING), was
        refused, or a REFLEX or FAULT stopped it. That goal stays hidden; the next one is drawn."""
        if self.goal is None or self.goal[0] is None or self.goal_ended:
            return False
        s = self.last_status
        if s is None or self.status_when < self.goal[2] + GOAL_ANSWER_S:
            return True
        running = s.state == controller_status_t.RUNNING and (self.goal[3] == "target" or bool(s.streaming))
        self.goal_ended = not running
        return running

    def law(self) -> Optional[int]:
        """The law in force: the status's, else the latest control mode's."""
        return self.last_status.law if self.last_status is not None else self.stiffness_law

    def draw(self, panel_now: bool = False) -> None:
        """Draws the newest messages, if any came since the last draw; the panel too, within
        PANEL_PERIOD_S of its last rewrite only if `panel_now` (a replay's seek: its new time is
        what the person waits to see)."""
        truth_stale = self.last_truth is not None and self.clock() - self.truth.when > TRUTH_STALE_S
        if not self._take() and not (truth_stale and self.truth_arrow.visible):
            self._panel(panel_now)
            return
        s = self.last_status
        with self.server.atomic():
            if self.q is not None:
                self._pose(self.arm, self.q)
            reference = s.q_desired if s is not None else self.driver_ghost
            actual = s.q if s is not None else self.q
            if reference is not None and actual is not None and np.max(np.abs(reference - actual)) > GHOST_THRESHOLD:
                self._pose(self.ghost, reference)
                self._show(self.ghost_root, True)
            else:
                self._show(self.ghost_root, False)
            if s is not None and (s.contact or s.contact_located_flag):
                if s.contact_link:
                    self._arrows(self.estimate_arrow, [s.contact_point], [s.contact_force])
                else:
                    self._arrows(self.estimate_arrow, [s.tip_position], [s.tip_wrench_ext[3:]])
            else:
                self._arrows(self.estimate_arrow, [], [])
            t = self.last_truth
            if t is not None and t.contact and not truth_stale:
                if t.num_contacts > 0:
                    self._arrows(self.truth_arrow, t.contact_point, t.contact_force)
                elif self.q is not None:
                    self._arrows(self.truth_arrow, [self.model.fk(self.q)[:3, 3]], [t.tip_wrench_ext[3:]])
            else:
                self._arrows(self.truth_arrow, [], [])
            if self.goal_shown():
                self._place(self.target_frame, self.goal[0])
            else:
                self._show(self.target_frame, False)
            if (self.law() == control_mode_t.CARTESIAN_IMPEDANCE and self.T_tip_stiffness is not None
                    and self.q is not None):
                self._place(self.stiffness_frame, self.model.fk(self.q) @ self.T_tip_stiffness)
            else:
                self._show(self.stiffness_frame, False)
            self._clearance(s)
        self.draws += 1
        self._panel(panel_now)

    def _clearance(self, s: Optional[Status]) -> None:
        """The closest pair's gap, witness to witness: red while that pair slows the motion."""
        if s is None or not s.clearance_pair:
            self._show(self.clearance_rod, False)
            return
        colour = SLOWING_COLOR if s.clearance_slowed_by == s.clearance_pair else CLEARANCE_COLOR
        points = s.clearance_points.reshape(1, 2, 3)
        sent = self._clearance_sent
        if sent is None or not np.array_equal(sent[0], points):
            self.clearance_rod.points = points
        if sent is None or sent[1] != colour:
            self.clearance_rod.colors = np.array([colour], np.uint8)
        self._clearance_sent = (points, colour)
        self._show(self.clearance_rod, True)

    def _panel(self, panel_now: bool = False) -> None:
        now = time.monotonic()
        mark_time, mark_states, mark_draws = self._rate_mark
        if now - mark_time >= 1.0:
            dt = now - mark_time
            self.rates = ((self.state.count - mark_states) / dt, (self.draws - mark_draws) / dt)
            self._rate_mark = (now, self.state.count, self.draws)
        if now - self._panel_sent < PANEL_PERIOD_S and not panel_now:
            return
        lines = [self.caption] if self.caption else []
        s = self.last_status
        if s is None:
            lines.append(f"**no status** on {self.prefix}STATUS yet")
        else:
            name = STATES.get(s.state, str(s.state))
            lines.append(f"**{name}**" + (f": {s.message}" if s.message else ""))
            lines.append(f"law {LAW_NAMES.get(s.law, s.law)}, payload {s.payload_mass:.3g} kg, "
                         f"ticks {s.ticks}")
            lines.append(f"tracking error {np.max(np.abs(s.tracking_error)):.2e} (max, rad or m)")
            force = np.linalg.norm(s.tip_wrench_ext[3:])
            contact = "yes" if s.contact else "no"
            where = f" on {s.contact_link}" if s.contact_link else ""
            lines.append(f"contact {contact}{where}, tip force estimate {force:.1f} N")
            if s.clearance_pair:
                slowing = ""
                if s.clearance_slowed_by:
                    who = "this pair" if s.clearance_slowed_by == s.clearance_pair else s.clearance_slowed_by
                    slowing = f", slowed by {who} (kept {100 * s.clearance_kept:.0f} %)"
                lines.append(f"clearance {s.clearance_distance:.3f} m: {s.clearance_pair}{slowing}")
        t = self.last_truth
        if t is not None:
            lines.append(f"true contact {'yes' if t.contact else 'no'}, tip force "
                         f"{np.linalg.norm(t.tip_wrench_ext[3:]):.1f} N, truth seq {t.seq}")
        if self.goal is not None:
            shown = "drawn" if self.goal_shown() else "hidden"
            where = "" if self.goal[0] is None else " at ({:.3f}, {:.3f}, {:.3f})".format(*self.goal[0][:3, 3])
            lines.append(f"{self.goal[1]}{where}, {shown}")
        if self.stiffness_frame.visible:
            lines.append("stiffness frame drawn at ({:.3f}, {:.3f}, {:.3f})".format(*self._pointed[id(self.stiffness_frame)][0]))
        if self.scene_summary != "none" or self.scene_problem:
            lines.append(f"scene: {self.scene_summary}" + (f"; {self.scene_problem}" if self.scene_problem else ""))
        seq = "none yet" if self.state_seq is None else (
            f"seq {self.state_seq}" if self.protocol == "chasles" else f"utime {self.state_seq}")
        if self.live:
            lines.append(f"state {seq}, {self.rates[0]:.0f} Hz heard, {self.rates[1]:.0f} Hz drawn")
            silent = [f"no {name} for {now - latest.when:.0f} s" for name, latest in
                      (("state", self.state), ("status", self.status)) if latest.count and now - latest.when >= SILENT_S]
            if silent:
                lines.append("**silent**: " + ", ".join(silent))
        else:
            lines.append(f"state {seq}")
        if self.notes:
            lines.append(f"{len(self.notes)} problem(s), the latest: {self.notes[-1]}")
        text = "  \n".join(lines)
        if text != self._panel_text:
            self.panel.content = text
            self._panel_text, self._panel_sent = text, now


def run(arms: Sequence[tuple], stop: threading.Event) -> None:
    """Hears the bus for every (view, lcm.LCM) and draws until `stop` is set. The one thread sleeps
    between draws and then takes every message each LCM queued meanwhile (the newest of each
    channel is kept): one wake-up a frame for all the arms, not one a message, which on a loaded
    machine costs more than the message. Arms on one provider URL share one LCM."""
    buses = []
    for view, lc in arms:
        for channel, handler in view.handlers().items():
            # A frame's worth at 1 kHz and then some: LCM drops what arrives at a full queue, the
            # newest included.
            lc.subscribe(channel, handler).set_queue_capacity(QUEUE_CAPACITY)
        if not any(lc is other for other in buses):
            buses.append(lc)
    period = min(view.period for view, _ in arms)
    next_draw = time.monotonic()
    while not stop.wait(max(0.0, next_draw - time.monotonic())):
        try:
            for lc in buses:
                while lc.handle_timeout(0) > 0:
                    pass
        except OSError:  # a signal that interrupts LCM's wait: SIGTERM or SIGINT ending the view
            if stop.is_set():
                break
            raise
        for view, _ in arms:
            view.draw()
        next_draw = max(next_draw + period, time.monotonic())
