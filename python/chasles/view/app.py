"""The live view: the arm as its latest robot_state_t puts it, the reference of the latest
controller_status_t as a ghost, the estimated and the true contact force as arrows, the
controller's state in the panel; served by viser (docs/view.md says why viser).

One thread hears the bus and draws. It wakes once a frame and takes what LCM queued meanwhile; each
handler keeps only its channel's newest message, as bytes: at 1 kHz decoding every state would
cost more than drawing, and a view that queued would fall behind. At most `rate` times a second
the newest ones are decoded, checked and drawn.
"""
from __future__ import annotations

import math
import sys
import threading
import time
from typing import Callable, Optional, Sequence

import numpy as np

from chasles._messages import STATES, Status
from chasles._command_checks import LAWS
from chasles.lcmtypes import controller_status_t, robot_state_t, sim_truth_t

from .shapes import Part

GHOST_COLOR = (40, 110, 255)
ESTIMATE_COLOR = (210, 0, 200)
TRUTH_COLOR = (0, 170, 60)
CAMERA_FOV_DEG = 50.0  # vertical field of view of the view's camera
GHOST_THRESHOLD = 1e-3  # rad or m: a reference nearer than this to q hides inside the arm anyway
TRUTH_STALE_S = 0.5  # a TRUTH channel silent this long no longer draws its arrows
SILENT_S = 1.0  # a channel heard before and silent this long is said so in the panel
PANEL_PERIOD_S = 0.1  # the panel's text is rewritten at most this often (the browser lays it out)
QUEUE_CAPACITY = 2000  # messages LCM keeps per channel between two draws (1 s at 1 kHz)
LAW_NAMES = {value: name for name, value in LAWS.items()}


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


def default_camera(model) -> tuple[np.ndarray, np.ndarray]:
    """(eye, target): the arm's links at q = 0 in view, from the front right and above."""
    origins = model.link_poses(np.zeros(model.nq))[:, :3, 3]
    low, high = origins.min(axis=0), origins.max(axis=0)
    target = (low + high) / 2
    reach = max(float(np.linalg.norm(high - low)), 0.3)
    direction = np.array([1.0, 0.75, 0.45])
    return target + 1.6 * reach * direction / np.linalg.norm(direction), target


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


class View:
    def __init__(self, server, model, parts: Sequence[Part], notes: Sequence[str], *, prefix: str = "CHASLES_",
                 rate: float = 30.0, force_scale: float = 0.01, camera: Optional[tuple] = None,
                 say: Callable[[str], None] = lambda text: print(text, file=sys.stderr, flush=True)):
        self.server, self.model, self.prefix = server, model, prefix
        self.period, self.force_scale, self.say = 1.0 / rate, force_scale, say
        # The time messages are judged fresh or silent by, s: the wall's; a replay sets the log's.
        self.live, self.clock = True, time.monotonic
        self.state, self.status, self.truth = Latest(self.clock), Latest(self.clock), Latest(self.clock)
        self.caption = ""  # a line of the panel's own, above the rest (the replay's time)
        self.notes: list[str] = []
        self.q: Optional[np.ndarray] = None
        self.state_seq: Optional[int] = None
        self.last_status: Optional[Status] = None
        self.last_truth = None
        self.draws = 0
        self.rates = (0.0, 0.0)  # states heard and draws, per second, over the last second
        self._rate_mark = (time.monotonic(), 0, 0)
        self._panel_text, self._panel_sent = "", 0.0
        self._posed, self._pointed = {}, {}  # the q each node set, and the points each arrow, last sent
        self._sent: dict = {}  # {node set: {link index: (position, wxyz) last sent}}
        for note in notes:
            self.note(note)
        self._build(parts, camera)

    # -- the scene --

    def _build(self, parts: Sequence[Part], camera: Optional[tuple]) -> None:
        scene = self.server.scene
        scene.set_up_direction("+z")
        # Shadows cost more than the rest of a frame in a software renderer (2.5 against ~8 fps in
        # headless Chromium's SwiftShader, 960×720) and say little about where the arm is.
        scene.configure_default_lights(cast_shadow=False)
        scene.configure_environment_map(None)
        eye, target = camera if camera is not None else default_camera(self.model)
        self.server.initial_camera.position = tuple(float(v) for v in eye)
        self.server.initial_camera.look_at = tuple(float(v) for v in target)
        self.server.initial_camera.up = (0.0, 0.0, 1.0)
        self.server.initial_camera.fov = math.radians(CAMERA_FOV_DEG)
        scene.add_grid("/grid", width=2.0, height=2.0, cell_size=0.1, section_size=0.5)
        # The chain's links nest in the scene tree, each posed in its parent's frame: a revolute
        # joint then changes only its child's orientation and a fixed joint nothing, one message
        # per moving joint a draw rather than two per link (viser's per-assignment cost is ~80 µs).
        self.arm, self.ghost = [], []
        self.ghost_root = scene.add_frame("/ghost", show_axes=False, visible=False)
        path = ""
        for link in self.model.link_names:
            path += f"/{link}"
            self.arm.append(scene.add_frame(f"/arm{path}", show_axes=False))
            self.ghost.append(scene.add_frame(f"/ghost{path}", show_axes=False))
            for k, part in enumerate(p for p in parts if p.link == link):
                pose = dict(position=part.T_lp[:3, 3], wxyz=quaternion_wxyz(part.T_lp[:3, :3]))
                if part.glb is not None:
                    scene.add_glb(f"/arm{path}/part{k}", part.glb, **pose)
                else:
                    scene.add_mesh_simple(f"/arm{path}/part{k}", part.vertices, part.faces, color=part.color, **pose)
                scene.add_mesh_simple(f"/ghost{path}/part{k}", part.vertices, part.faces, color=GHOST_COLOR,
                                      opacity=0.35, cast_shadow=False, receive_shadow=False, **pose)
        arrow = dict(shaft_radius=0.01, head_radius=0.025, head_length=0.05, visible=False)
        self.estimate_arrow = scene.add_arrows("/force/estimate", np.zeros((1, 2, 3)), ESTIMATE_COLOR, **arrow)
        self.truth_arrow = scene.add_arrows("/force/truth", np.zeros((1, 2, 3)), TRUTH_COLOR, **arrow)
        self.panel = self.server.gui.add_markdown("waiting for the arm's state")
        self._pose(self.arm, np.zeros(self.model.nq))

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
            self.say(f"chasles view: {text}")

    def handlers(self) -> dict:
        """{channel: the handler that keeps its newest bytes}."""
        return {self.prefix + "STATE": self.state, self.prefix + "STATUS": self.status, self.prefix + "TRUTH": self.truth}

    def _decode(self, kind, data: bytes, channel: str):
        try:
            return kind.decode(data)
        except Exception as e:  # another type on the channel, or bytes cut short
            self.note(f"{channel}: a message that is no {kind.__name__} ({e or type(e).__name__}): skipped")
            return None

    def _take(self) -> bool:
        """Decodes and checks the newest messages; True when there is something new to draw."""
        nq, changed = self.model.nq, False
        data = self.state.fresh()
        if data is not None:
            m = self._decode(robot_state_t, data, self.prefix + "STATE")
            if m is not None:
                q = np.array(m.position, float)
                problem = check_joints(self.prefix + "STATE", {"position": q}, nq)
                if problem:
                    self.note(problem)
                else:
                    self.q, self.state_seq, changed = q, m.seq, True
        data = self.status.fresh()
        if data is not None:
            m = self._decode(controller_status_t, data, self.prefix + "STATUS")
            if m is not None:
                s = Status.from_message(m)
                problem = check_joints(self.prefix + "STATUS", {"q": s.q, "q_desired": s.q_desired}, nq)
                if not problem and not (np.all(np.isfinite(s.tip_wrench_ext)) and np.all(np.isfinite(s.contact_point))
                                        and np.all(np.isfinite(s.contact_force)) and np.all(np.isfinite(s.tip_position))):
                    problem = f"{self.prefix}STATUS: a contact field is not finite: messages like it skipped"
                if problem:
                    self.note(problem)
                else:
                    self.last_status, changed = s, True
                    if self.state.count == 0:  # a controller heard before its arm: its q
                        self.q = s.q
        data = self.truth.fresh()
        if data is not None:
            m = self._decode(sim_truth_t, data, self.prefix + "TRUTH")
            if m is not None:
                values = [m.tip_wrench_ext, *m.contact_point, *m.contact_force]
                if not all(np.all(np.isfinite(v)) for v in values):
                    self.note(f"{self.prefix}TRUTH: a contact field is not finite: messages like it skipped")
                else:
                    self.last_truth, changed = m, True
        return changed

    def draw(self) -> None:
        """Draws the newest messages, if any came since the last draw."""
        truth_stale = self.last_truth is not None and self.clock() - self.truth.when > TRUTH_STALE_S
        if not self._take() and not (truth_stale and self.truth_arrow.visible):
            self._panel()
            return
        s = self.last_status
        with self.server.atomic():
            if self.q is not None:
                self._pose(self.arm, self.q)
            if s is not None and np.max(np.abs(s.q_desired - s.q)) > GHOST_THRESHOLD:
                self._pose(self.ghost, s.q_desired)
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
        self.draws += 1
        self._panel()

    def _panel(self) -> None:
        now = time.monotonic()
        mark_time, mark_states, mark_draws = self._rate_mark
        if now - mark_time >= 1.0:
            dt = now - mark_time
            self.rates = ((self.state.count - mark_states) / dt, (self.draws - mark_draws) / dt)
            self._rate_mark = (now, self.state.count, self.draws)
        if now - self._panel_sent < PANEL_PERIOD_S:
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
        t = self.last_truth
        if t is not None:
            lines.append(f"true contact {'yes' if t.contact else 'no'}, tip force "
                         f"{np.linalg.norm(t.tip_wrench_ext[3:]):.1f} N, truth seq {t.seq}")
        seq = "none yet" if self.state_seq is None else f"seq {self.state_seq}"
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

    def run(self, lc, stop: threading.Event) -> None:
        """Hears the bus and draws until `stop` is set. The thread sleeps between draws and then
        takes every message LCM queued meanwhile (the newest of each channel is kept): one wake-up
        a frame, not one a message, which on a loaded machine costs more than the message."""
        for channel, handler in self.handlers().items():
            # A frame's worth at 1 kHz and then some: LCM drops what arrives at a full queue, the
            # newest included.
            lc.subscribe(channel, handler).set_queue_capacity(QUEUE_CAPACITY)
        next_draw = time.monotonic()
        while not stop.wait(max(0.0, next_draw - time.monotonic())):
            try:
                while lc.handle_timeout(0) > 0:
                    pass
            except OSError:  # a signal that interrupts LCM's wait: SIGTERM or SIGINT ending the view
                if stop.is_set():
                    break
                raise
            self.draw()
            next_draw = max(next_draw + self.period, time.monotonic())
