"""The live view: the arm as its latest robot_state_t puts it, the reference of the latest
controller_status_t as a ghost, the estimated and the true contact force as arrows, the
controller's state in the panel; served by viser (docs/view.md says why viser).

One thread hears the bus and draws. Each handler keeps only its channel's newest message, as bytes:
at 1 kHz decoding every state would cost more than drawing, and a view that queued would fall
behind. At most `rate` times a second the newest ones are decoded, checked and drawn.
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
LAW_NAMES = {value: name for name, value in LAWS.items()}


def quaternion_wxyz(R: np.ndarray) -> np.ndarray:
    """The unit quaternions (w, x, y, z) of rotation matrices (..., 3, 3), by Shepperd's method:
    from the largest of 1 + trace, 1 + 2 R_ii - trace, so that no branch divides by a small
    number. Vectorised: one draw converts every link at once."""
    R = np.asarray(R, float)
    shape = R.shape[:-2]
    R = R.reshape(-1, 3, 3)
    t = np.trace(R, axis1=1, axis2=2)
    d = np.stack([t, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], axis=1)
    big = np.argmax(d, axis=1)
    s = np.stack([1 + t, 1 + 2 * R[:, 0, 0] - t, 1 + 2 * R[:, 1, 1] - t, 1 + 2 * R[:, 2, 2] - t], axis=1)
    # Each row of `pairs` is 4 q_i q_j for the quaternion's four entries i, given j = big.
    a = R[:, 2, 1] - R[:, 1, 2]
    b = R[:, 0, 2] - R[:, 2, 0]
    c = R[:, 1, 0] - R[:, 0, 1]
    e = R[:, 0, 1] + R[:, 1, 0]
    f = R[:, 0, 2] + R[:, 2, 0]
    g = R[:, 1, 2] + R[:, 2, 1]
    pairs = np.stack([np.stack([s[:, 0], a, b, c], axis=1), np.stack([a, s[:, 1], e, f], axis=1),
                      np.stack([b, e, s[:, 2], g], axis=1), np.stack([c, f, g, s[:, 3]], axis=1)], axis=1)
    rows = pairs[np.arange(len(R)), big]  # 4 q_big q
    q = rows / np.linalg.norm(rows, axis=1, keepdims=True)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)  # w >= 0: one of the two for each rotation
    return q.reshape(*shape, 4)


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
                 say: Callable[[str], None] = lambda text: print(text, file=sys.stderr, flush=True),
                 clock: Optional[Callable[[], float]] = None):
        """clock: the time messages are judged fresh or silent by, s (default the wall's,
        time.monotonic; a replay gives the log's)."""
        self.server, self.model, self.prefix = server, model, prefix
        self.period, self.force_scale, self.say = 1.0 / rate, force_scale, say
        self.live = clock is None
        self.clock = clock or time.monotonic
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
        links = list(self.model.link_names)
        self.arm, self.ghost = {}, {}
        self.ghost_root = scene.add_frame("/ghost", show_axes=False, visible=False)
        for i, link in enumerate(links):
            mine = [p for p in parts if p.link == link]
            if not mine:
                continue
            self.arm[i] = scene.add_frame(f"/arm/{link}", show_axes=False)
            self.ghost[i] = scene.add_frame(f"/ghost/{link}", show_axes=False)
            for k, part in enumerate(mine):
                pose = dict(position=part.T_lp[:3, 3], wxyz=quaternion_wxyz(part.T_lp[:3, :3]))
                if part.glb is not None:
                    scene.add_glb(f"/arm/{link}/{k}", part.glb, **pose)
                else:
                    scene.add_mesh_simple(f"/arm/{link}/{k}", part.vertices, part.faces, color=part.color, **pose)
                scene.add_mesh_simple(f"/ghost/{link}/{k}", part.vertices, part.faces, color=GHOST_COLOR,
                                      opacity=0.35, cast_shadow=False, receive_shadow=False, **pose)
        arrow = dict(shaft_radius=0.01, head_radius=0.025, head_length=0.05, visible=False)
        self.estimate_arrow = scene.add_arrows("/force/estimate", np.zeros((1, 2, 3)), ESTIMATE_COLOR, **arrow)
        self.truth_arrow = scene.add_arrows("/force/truth", np.zeros((1, 2, 3)), TRUTH_COLOR, **arrow)
        self.panel = self.server.gui.add_markdown("waiting for the arm's state")
        self._pose(self.arm, np.zeros(self.model.nq))

    def _pose(self, nodes: dict, q: np.ndarray) -> None:
        T = self.model.link_poses(q)
        wxyz = quaternion_wxyz(T[:, :3, :3])
        for i, node in nodes.items():
            node.position = T[i, :3, 3]
            node.wxyz = wxyz[i]

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
        handle.points = np.stack([p - self.force_scale * f, p], axis=1)
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

    def subscribe(self, lc) -> None:
        for channel, handler in self.handlers().items():
            lc.subscribe(channel, handler)

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
        """Hears the bus and draws until `stop` is set."""
        self.subscribe(lc)
        next_draw = time.monotonic()
        while not stop.is_set():
            wait = next_draw - time.monotonic()
            if wait > 0:
                try:
                    lc.handle_timeout(max(1, int(wait * 1000)))
                except OSError:  # a signal that interrupts LCM's wait: SIGTERM or SIGINT ending the view
                    if stop.is_set():
                        break
                    raise
                continue
            self.draw()
            next_draw = max(next_draw + self.period, time.monotonic())
