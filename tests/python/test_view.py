"""chasles.view as a person sees it: the view runs as a process (python -m chasles.view) on the
Panda, this test publishes real robot_state_t, controller_status_t and sim_truth_t messages on the
namespace's bus, and headless Chromium loads the page and takes screenshots.

Where things should be drawn is worked out here, independently of the view: chasles's FK places
the links (the reference), and a pinhole camera with the view's eye, target and field of view
(view_browser.project) puts them on the screen. Each wait is on the page's own text (the panel
names the state seq and the status ticks it has drawn), never a fixed sleep.

Needs the test's network namespace (NETNS) for the bus, and Chromium (tools/deps.sh).
"""
from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import threading
import time

import lcm
import numpy as np
import pytest

import chasles
from chasles.lcmtypes import controller_status_t, robot_state_t, sim_truth_t
from chasles.view.app import CAMERA_FOV_DEG
from view_browser import Browser, chromium_path, project, served_view

LCM_URL = "udpm://239.255.76.67:7667?ttl=0"
DATA = os.environ["CHASLES_TEST_DATA"]
URDF, TIP = os.path.join(DATA, "panda.urdf"), "panda_hand"
W, H = 960, 720
EYE, TARGET = (1.6, 1.1, 0.9), (0.2, 0.0, 0.45)
# Two poses whose hands are far apart on the screen, each in open background in the other.
Q1 = np.array([0.3, -0.4, 0.0, -2.0, 0.0, 1.6, 0.8])
Q2 = np.array([-0.9, -0.4, 0.0, -2.0, 0.0, 1.6, 0.8])
# What the page lays over the 3D canvas: Chromium's software-WebGL notice (top left) and the panel.
OVERLAYS = [(0, 0, 320, 200), (615, 0, W, 200)]

MODEL = chasles.Model.from_urdf(URDF, tip=TIP)


def screen(points) -> np.ndarray:
    return project(points, EYE, TARGET, CAMERA_FOV_DEG, W, H)


def disc(image: np.ndarray, uv, radius: int = 4) -> np.ndarray:
    """The pixels within `radius` of uv, (N, 3) int."""
    u, v = uv
    assert radius <= u < W - radius and radius <= v < H - radius, f"{uv} is off the screen"
    for x0, y0, x1, y1 in OVERLAYS:
        assert not (x0 <= u <= x1 and y0 <= v <= y1), f"{uv} is under the page's overlay {(x0, y0, x1, y1)}"
    ys, xs = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    keep = xs**2 + ys**2 <= radius**2
    return image[int(round(v)) + ys[keep], int(round(u)) + xs[keep]].astype(int)


# The colours of chasles.view.shapes.ARM_COLOR (orange, hue 28°), app.GHOST_COLOR (blue, 222°, at
# 35 % opacity over a light background), ESTIMATE_COLOR (magenta, 303°) and TRUTH_COLOR (green,
# 141°), told apart by hue and saturation: the lighting changes their brightness, from a lit face
# to one in shade, but hardly their hue. The background, the grid and the panel are greys.
def hue_saturation(p):
    p = p.astype(float)
    high, low = p.max(axis=1), p.min(axis=1)
    span = np.maximum(high - low, 1e-9)
    r, g, b = p.T
    hue = np.where(high == r, (g - b) / span % 6, np.where(high == g, (b - r) / span + 2, (r - g) / span + 4)) * 60
    return hue, (high - low) / np.maximum(high, 1e-9), high


def arm(p):
    hue, saturation, value = hue_saturation(p)
    return (hue >= 8) & (hue <= 45) & (saturation > 0.45) & (value > 25)


def ghost(p):
    hue, saturation, _ = hue_saturation(p)
    return (hue >= 200) & (hue <= 240) & (saturation > 0.15)


def magenta(p):
    hue, saturation, _ = hue_saturation(p)
    return (hue >= 280) & (hue <= 325) & (saturation > 0.5)


def green(p):
    hue, saturation, _ = hue_saturation(p)
    return (hue >= 120) & (hue <= 165) & (saturation > 0.5)


def share(image, uv, colour, radius: int = 4) -> float:
    return float(np.mean(colour(disc(image, uv, radius))))


@pytest.fixture(scope="module")
def view():
    with served_view(["--urdf", URDF, "--tip", TIP, "--package-dir", os.path.join(DATA, "packages"), "--url", LCM_URL,
                      "--camera", ",".join(str(v) for v in EYE + TARGET)], timeout=60) as process:
        yield process


@pytest.fixture(scope="module")
def page(view):
    assert chromium_path(), "chromium not found (tools/deps.sh installs chasles_packages_view)"
    browser = Browser(W, H)
    try:
        browser.open(view.url)
        browser.wait_text(r"chasles view|no status", timeout=60)
        yield browser
    finally:
        browser.close()


@pytest.fixture(scope="module")
def bus():
    seat = Bus()
    yield seat
    seat.stop()


def state(q, seq: int) -> robot_state_t:
    m = robot_state_t()
    m.utime, m.seq, m.num_joints = int(time.time() * 1e6), seq, len(q)
    m.position, m.velocity, m.effort = list(map(float, q)), [0.0] * len(q), [0.0] * len(q)
    return m


def status(q, q_desired, ticks: int, force=None) -> controller_status_t:
    """A controller_status_t as the controller fills the fields the view reads (the rest zero)."""
    n = len(q)
    m = controller_status_t()
    m.utime, m.state, m.message, m.num_joints = int(time.time() * 1e6), controller_status_t.RUNNING, "", n
    m.q, m.q_desired = list(map(float, q)), list(map(float, q_desired))
    m.tracking_error = list(np.subtract(q_desired, q))
    m.tip_position = list(MODEL.fk(q)[:3, 3]) if n == MODEL.nq else [0.0, 0.0, 0.0]
    m.tip_quaternion = [1.0, 0.0, 0.0, 0.0]
    for name in ("torque", "tau_ext", "generator_velocity_limit", "generator_acceleration_limit",
                 "generator_jerk_limit"):
        setattr(m, name, [0.0] * n)
    m.tip_wrench_ext = [0.0, 0.0, 0.0, *(force if force is not None else (0.0, 0.0, 0.0))]
    m.contact = force is not None
    m.ticks = ticks
    m.trajectory_time_scale = m.jog_scale = m.clearance_kept = 1.0
    m.jog_joint = -1
    return m


class Bus:
    """The test's seat on the namespace's bus. Like a plant, it goes on sending its latest messages
    (every 20 ms) until it is given others or stopped: the view judges a channel silent after a
    while, so what a screenshot shows must still be on the bus when it is taken."""

    def __init__(self):
        self.lc = lcm.LCM(LCM_URL)
        self._done, self._sender = threading.Event(), None

    def publish(self, channel: str, message) -> None:
        self.lc.publish(channel, message if isinstance(message, bytes) else message.encode())

    def stop(self) -> None:
        if self._sender is not None:
            self._done.set()
            self._sender.join()
            self._sender = None

    def send_until(self, page, messages: dict, pattern: str, timeout: float = 30.0) -> str:
        """Sends {channel: message or bytes} until the page's text matches `pattern` (the view has
        drawn them) and on after; renders a few frames; returns the page's text."""
        self.stop()
        done = self._done = threading.Event()

        def send():
            while not done.is_set():
                for channel, message in messages.items():
                    self.publish(channel, message)
                done.wait(0.02)

        self._sender = threading.Thread(target=send, daemon=True)
        self._sender.start()
        text = page.wait_text(pattern, timeout)
        page.frames(3)
        return text


def shot(page, name: str) -> np.ndarray:
    """A screenshot; kept as NAME.png in $CHASLES_VIEW_SHOTS when it is set, to look at."""
    image = page.screenshot()
    folder = os.environ.get("CHASLES_VIEW_SHOTS")
    if folder:
        from PIL import Image
        os.makedirs(folder, exist_ok=True)
        Image.fromarray(image).save(os.path.join(folder, name + ".png"))
    return image


def tip(q) -> np.ndarray:
    return MODEL.fk(q)[:3, 3]


def test_the_arm_is_drawn_where_fk_puts_it(page, bus):
    bus.send_until(page, {"CHASLES_STATE": state(Q1, 11)}, r"state seq 11,")
    at_q1 = shot(page, "at_q1")
    bus.send_until(page, {"CHASLES_STATE": state(Q2, 12)}, r"state seq 12,")
    at_q2 = shot(page, "at_q2")
    hand1, hand2 = screen([tip(Q1), tip(Q2)])
    assert np.linalg.norm(hand1 - hand2) > 100, "the two poses' hands are too near on the screen"
    # The hand is where FK puts it, in each pose, and background where the other pose had it.
    assert share(at_q1, hand1, arm) > 0.8, at_q1[int(hand1[1]), int(hand1[0])]
    assert share(at_q2, hand2, arm) > 0.8, at_q2[int(hand2[1]), int(hand2[0])]
    assert share(at_q1, hand2, arm) == 0.0
    assert share(at_q2, hand1, arm) == 0.0
    # Every link origin of the chain above the base, in both poses.
    for q, image in ((Q1, at_q1), (Q2, at_q2)):
        for name, uv in zip(MODEL.link_names[1:], screen(MODEL.link_poses(q)[1:, :3, 3])):
            assert share(image, uv, arm, radius=3) > 0.5, f"{name} at {uv.round()}: {image[int(uv[1]), int(uv[0])]}"
    # The background far from the arm: the screen's lower corners and middle, its left and right.
    for uv in [(40, H - 40), (W - 40, H - 40), (W / 2, H - 40), (100, H / 2), (W - 100, H / 2)]:
        assert share(at_q1, uv, arm) == 0.0 and share(at_q2, uv, arm) == 0.0, uv


def test_the_reference_is_a_ghost_while_it_is_away_from_the_arm(page, bus):
    hand2 = screen([tip(Q2)])[0]
    away = bus.send_until(page, {"CHASLES_STATE": state(Q1, 21), "CHASLES_STATUS": status(Q1, Q2, 2001)},
                         r"ticks 2001")
    assert "RUNNING" in away
    with_ghost = shot(page, "with_ghost")
    bus.send_until(page, {"CHASLES_STATE": state(Q1, 22), "CHASLES_STATUS": status(Q1, Q1, 2002)},
                  r"ticks 2002")
    without = shot(page, "without_ghost")
    assert share(with_ghost, hand2, ghost) > 0.8, with_ghost[int(hand2[1]), int(hand2[0])]
    assert share(without, hand2, ghost) == 0.0
    assert share(without, hand2, arm) == 0.0
    # The arm itself stays where its state puts it.
    hand1 = screen([tip(Q1)])[0]
    assert share(with_ghost, hand1, arm) > 0.8 and share(without, hand1, arm) > 0.8


def test_contact_forces_are_arrows_into_the_arm(page, bus):
    force = np.array([0.0, 0.0, -40.0])  # N, pressing down on the hand
    scale = 0.01  # m/N, the view's default --force-scale
    # The arrow ends at the point, along the force: its middle is half its length up, against it.
    middle = screen([tip(Q1) - 0.5 * scale * force])[0]
    below = screen([tip(Q1) + 0.5 * scale * force])[0]
    pressed = bus.send_until(page, {"CHASLES_STATE": state(Q1, 31),
                                        "CHASLES_STATUS": status(Q1, Q1, 3001, force=force)}, r"ticks 3001")
    assert "contact yes" in pressed and "tip force estimate 40.0 N" in pressed
    with_arrow = shot(page, "with_arrow")
    bus.send_until(page, {"CHASLES_STATE": state(Q1, 32), "CHASLES_STATUS": status(Q1, Q1, 3002)},
                  r"ticks 3002")
    without = shot(page, "without_arrow")
    assert share(with_arrow, middle, magenta, radius=2) > 0.8, with_arrow[int(middle[1]), int(middle[0])]
    assert share(without, middle, magenta, radius=2) == 0.0
    assert share(with_arrow, below, magenta) == 0.0

    # The plant's truth: one contact on link 4's origin (the elbow), pressed down.
    point = MODEL.link_poses(Q1)[4, :3, 3]
    push = np.array([0.0, 0.0, -30.0])
    truth = sim_truth_t()
    truth.utime, truth.seq, truth.num_joints, truth.tau_ext = int(time.time() * 1e6), 41, 7, [0.0] * 7
    truth.tip_wrench_ext, truth.contact, truth.num_contacts = [0.0] * 6, True, 1
    truth.contact_link, truth.contact_other = ["panda_link4"], ["pusher"]
    truth.contact_point, truth.contact_normal, truth.contact_force = [list(point)], [[0.0, -1.0, 0.0]], [list(push)]
    true_middle = screen([point - 0.5 * scale * push])[0]
    bus.send_until(page, {"CHASLES_STATE": state(Q1, 33), "CHASLES_TRUTH": truth}, r"truth seq 41")
    with_truth = shot(page, "with_truth")
    truth.seq, truth.contact, truth.num_contacts = 42, False, 0
    truth.contact_link = truth.contact_other = truth.contact_point = truth.contact_normal = truth.contact_force = []
    bus.send_until(page, {"CHASLES_STATE": state(Q1, 34), "CHASLES_TRUTH": truth}, r"truth seq 42")
    without_truth = shot(page, "without_truth")
    assert share(with_truth, true_middle, green, radius=2) > 0.8, with_truth[int(true_middle[1]), int(true_middle[0])]
    assert share(without_truth, true_middle, green, radius=2) == 0.0


def test_bad_messages_are_said_and_skipped(view, page, bus):
    hand1, hand2 = screen([tip(Q1), tip(Q2)])
    bus.send_until(page, {"CHASLES_STATE": state(Q1, 51)}, r"state seq 51,")
    cases = [(state(Q2[:6], 52), r"CHASLES_STATE: position has 6 entries, the model has 7 joints"),
             (state(np.where(np.arange(7) == 2, math.nan, Q2), 53), r"CHASLES_STATE: position\[2\] is nan"),
             (b"not a message", r"CHASLES_STATE: a message that is no robot_state_t")]
    for message, said in cases:
        text = bus.send_until(page, {"CHASLES_STATE": message}, said)
        assert "state seq 51," in text  # the last good state is still the one drawn
    text = bus.send_until(page, {"CHASLES_STATUS": status(Q2[:6], Q2[:6], 5001)},
                         r"CHASLES_STATUS: q has 6 entries, the model has 7 joints")
    assert "ticks 5001" not in text
    # And the view goes on: the next good state is drawn.
    bus.send_until(page, {"CHASLES_STATE": state(Q2, 54)}, r"state seq 54,")
    image = shot(page, "after_bad")
    assert share(image, hand2, arm) > 0.8 and share(image, hand1, arm) == 0.0
    assert view.poll() is None
    bus.stop()
    page.wait_text(r"silent: no state for [1-9]\d* s", timeout=30)  # and says when the bus falls quiet
    for _, said in cases:  # each said once on stderr too (read when the view ends)
        view.expected_notes.append(said.replace("\\", ""))


def test_a_1khz_bus_is_drawn_newest_first_at_most_at_the_rate(page, bus):
    """States at 1 kHz, moving, for 3 s: every seq the panel shows is one already sent and none
    goes back, the draws a second never exceed the rate, and the last state sent is the one left
    drawn. What holds whatever the machine's load; how fast and for how much CPU is measured by
    tests/python/view_cpu.py (docs/view.md)."""
    count, period, first = 3000, 1e-3, 1000
    sent = [0]  # states published so far

    def send():
        start = time.monotonic()
        for k in range(count):
            bus.publish("CHASLES_STATE", state(Q1 + 0.3 * math.sin(2 * math.pi * 0.5 * k * period), first + k))
            sent[0] = k + 1
            delay = start + (k + 1) * period - time.monotonic()
            if delay > 0:
                time.sleep(delay)

    bus.stop()
    sender = threading.Thread(target=send)
    sender.start()
    shown = []  # (seq drawn, states sent by then, draws a second) as the page showed them
    try:
        while sender.is_alive():
            text = page.text()
            match = re.search(r"state seq (\d+), \d+ Hz heard, (\d+) Hz drawn", text)
            if match and int(match.group(1)) >= first:
                shown.append((int(match.group(1)), sent[0], int(match.group(2))))
            time.sleep(0.05)  # the poll's pace; nothing waits on it
    finally:
        sender.join()
    last = first + count - 1
    text = page.wait_text(rf"state seq {last},", timeout=30)
    assert shown, f"no state of the stream was shown while it was sent; the page shows:\n{text}"
    seqs = [seq for seq, _, _ in shown]
    assert seqs == sorted(seqs), f"a seq went back: {seqs}"
    for seq, by_then, _ in shown:
        assert seq < first + by_then, f"seq {seq} shown when only {by_then} states were sent"
    # The panel counts draws over windows of dt >= 1 s, and the loop waits a period (1/30 s)
    # between them: at most 30 dt + 1 a window, 31 a second.
    assert max(drawn for _, _, drawn in shown) <= 31, shown


# -- a log replayed: python -m chasles.view LOG --------------------------------------------------

def write_log(path: str) -> None:
    """3 s as lcm-logger would have written them: states at 100 Hz (Q1 until 1.5 s, then Q2) and
    statuses at 10 Hz, feeling 40 N down on the hand from 2 s on."""
    log = lcm.EventLog(path, "w", overwrite=True)
    t0 = 1_700_000_000_000_000
    for k in range(300):
        t = k * 0.01
        q = Q1 if t < 1.5 else Q2
        m = state(q, k)
        m.utime, m.effort = t0 + k * 10_000, list(np.sin(t + np.arange(7)))
        log.write_event(m.utime, "CHASLES_STATE", m.encode())
        if k % 10 == 5:
            m = status(q, q, 9000 + k, force=(0.0, 0.0, -40.0) if t >= 2.0 else None)
            m.utime = t0 + k * 10_000
            log.write_event(m.utime + 100, "CHASLES_STATUS", m.encode())
    log.close()


def test_a_log_replays_on_its_own_clock_with_its_controls(tmp_path):
    path = str(tmp_path / "run.lcmlog")
    write_log(path)
    argv = [sys.executable, "-m", "chasles.view", path, "--urdf", URDF, "--tip", TIP,
            "--package-dir", os.path.join(DATA, "packages"), "--port", "0", "--paused", "--speed", "4",
            "--camera", ",".join(str(v) for v in EYE + TARGET)]
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    browser = None
    try:
        line = process.stdout.readline()
        url = re.fullmatch(r"chasles view: (http://127\.0\.0\.1:\d+)\s*", line)
        assert url, f"no address: {line!r}"
        browser = Browser(W, H)
        browser.open(url.group(1))
        text = browser.wait_text(r"log 0\.000 s of 2\.990 s, paused", timeout=60)
        assert "state seq 0" in text
        for title in ("joints (rad or m)", "torques applied (N·m or N)", "tip force |f| (N)"):
            assert title in text
        browser.frames(3)
        hand1, hand2 = screen([tip(Q1), tip(Q2)])
        start = browser.screenshot()
        assert share(start, hand1, arm) > 0.8 and share(start, hand2, arm) == 0.0

        # Play at ×4: the log's time never runs ahead of 4 × the wall's since the click (the page
        # may show it late, never early) and never goes back, and the replay stops at its end.
        # (How late, on a loaded machine, is no test's business.)
        clicked = time.monotonic()
        browser.evaluate("[...document.querySelectorAll('button')].find(b => b.innerText === 'Play').click()")
        seen = []
        deadline = clicked + 60
        while True:
            text = browser.text()
            shown = float(re.search(r"log (\d+\.\d+) s of", text).group(1))
            elapsed = time.monotonic() - clicked
            assert shown <= 4 * elapsed + 0.001, f"log time {shown} s after {elapsed:.3f} s of wall time at ×4"
            seen.append(shown)
            if re.search(r"log 2\.990 s of 2\.990 s, paused", text):
                break
            assert time.monotonic() < deadline, f"the replay never reached its end; the page shows:\n{text}"
            time.sleep(0.02)  # the poll's pace
        assert seen == sorted(seen), f"the log's time went back while playing: {seen}"
        assert "state seq 299" in text and "ticks 9295" in text and "contact yes" in text
        browser.frames(3)
        end = browser.screenshot()
        middle = screen([tip(Q2) + [0.0, 0.0, 0.2]])[0]  # the 40 N arrow's middle, 0.01 m/N
        assert share(end, hand2, arm) > 0.8 and share(end, hand1, arm) == 0.0
        assert share(end, middle, magenta, radius=2) > 0.8

        # The slider, from the keyboard as a person may: Home goes back to the start. First the
        # slider shows the end too (its last update came after the panel's), as a person sees it.
        thumb = "document.querySelector('[role=slider]')"
        deadline = time.monotonic() + 30
        while browser.evaluate(f"{thumb}.getAttribute('aria-valuenow')") != "2.99":
            assert time.monotonic() < deadline, "the slider never showed the log's end"
            time.sleep(0.02)
        browser.evaluate(f"{thumb}.focus()")
        for kind in ("keyDown", "keyUp"):
            browser.call("Input.dispatchKeyEvent", type=kind, key="Home", code="Home", windowsVirtualKeyCode=36)
        try:
            text = browser.wait_text(r"log 0\.000 s of 2\.990 s, paused", timeout=30)
        except TimeoutError as e:
            slider = browser.evaluate("document.querySelector('[role=slider]').getAttribute('aria-valuenow')")
            raise TimeoutError(f"{e}\nthe slider shows {slider}") from None
        assert "state seq 0" in text
        browser.frames(3)
        back = browser.screenshot()
        assert share(back, hand1, arm) > 0.8 and share(back, hand2, arm) == 0.0
    finally:
        if browser is not None:
            browser.close()
        process.terminate()
        assert process.wait(timeout=10) == 0


def test_a_damaged_log_is_refused_with_where(tmp_path):
    path = tmp_path / "damaged.lcmlog"
    write_log(str(path))
    path.write_bytes(path.read_bytes()[:1000])  # cut inside an event, as a killed logger leaves it
    run = subprocess.run([sys.executable, "-m", "chasles.view", str(path), "--urdf", URDF, "--tip", TIP, "--port", "0"],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 1 and run.stdout == ""
    assert re.search(r"chasles view: .*damaged\.lcmlog: byte \d+: event #\d+ is cut short", run.stderr), run.stderr

# -- what is drawn, without a browser: chasles.view.shapes on chasles's own small arm --------------

def rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def transform(R=np.eye(3), p=(0.0, 0.0, 0.0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def test_shapes_ride_on_their_chain_links_with_their_origins_and_fall_back_to_collisions(tmp_path):
    import xml.etree.ElementTree as ET

    import trimesh

    from chasles.view.shapes import ARM_COLOR, load_parts

    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    box.visual.face_colors = [200, 0, 0, 255]
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "box.dae").write_bytes(trimesh.exchange.dae.export_collada(box))
    robot = ET.parse(os.path.join(DATA, "arm.urdf")).getroot()
    ET.SubElement(robot, "material", name="blue").append(ET.Element("color", rgba="0 0 1 1"))
    links = {link.get("name"): link for link in robot.findall("link")}
    # finger: off the chain (a prismatic joint at (0, 0.05, 0) on l2), a box turned 0.3 rad about z.
    links["finger"].append(ET.fromstring(
        '<visual><origin xyz="0.01 0 0" rpy="0 0 0.3"/><geometry><box size="0.02 0.04 0.06"/></geometry>'
        '<material name="blue"/></visual>'))
    # l1b: its visual's package is nowhere; its collision cylinder is drawn instead.
    links["l1b"].append(ET.fromstring('<visual><geometry><mesh filename="package://nopkg/x.stl"/></geometry></visual>'))
    links["l1b"].append(ET.fromstring(
        '<collision><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.03" length="0.1"/></geometry></collision>'))
    # tip: a Collada file of its own, relative to the URDF, scaled.
    links["tip"].append(ET.fromstring(
        '<visual><geometry><mesh filename="meshes/box.dae" scale="0.1 0.2 0.3"/></geometry></visual>'))
    # base: a file that holds no mesh, and no collision.
    (tmp_path / "meshes" / "broken.stl").write_text("not a mesh")
    links["base"].append(ET.fromstring('<visual><geometry><mesh filename="meshes/broken.stl"/></geometry></visual>'))
    urdf = tmp_path / "arm.urdf"
    ET.ElementTree(robot).write(urdf)
    model = chasles.Model.from_urdf(str(urdf), tip="tip")

    parts, notes = load_parts(str(urdf), model.link_names, [])
    by_source = {p.source: p for p in parts}
    assert set(by_source) == {"link 'finger' <visual> 0", "link 'l1b' <collision> 0", "link 'tip' <visual> 0"}

    finger = by_source["link 'finger' <visual> 0"]
    assert finger.link == "l2" and finger.color == (0, 0, 255) and finger.glb is None
    np.testing.assert_allclose(finger.T_lp, transform(p=(0, 0.05, 0)) @ transform(rz(0.3), (0.01, 0, 0)), atol=1e-15)
    np.testing.assert_allclose(finger.vertices.min(axis=0), [-0.01, -0.02, -0.03], atol=1e-7)
    np.testing.assert_allclose(finger.vertices.max(axis=0), [0.01, 0.02, 0.03], atol=1e-7)

    cylinder = by_source["link 'l1b' <collision> 0"]
    assert cylinder.link == "l1b" and cylinder.color == ARM_COLOR
    np.testing.assert_allclose(cylinder.T_lp, transform(p=(0, 0, 0.1)))
    np.testing.assert_allclose(cylinder.vertices.min(axis=0), [-0.03, -0.03, -0.05], atol=1e-3)

    dae = by_source["link 'tip' <visual> 0"]
    assert dae.link == "tip" and dae.glb is not None and dae.glb[:4] == b"glTF"
    np.testing.assert_allclose(dae.vertices.min(axis=0), [-0.05, -0.1, -0.15], atol=1e-7)
    np.testing.assert_allclose(dae.vertices.max(axis=0), [0.05, 0.1, 0.15], atol=1e-7)

    assert len(notes) == 3, notes
    assert notes[0].startswith("link 'base' <visual> 0: ") and notes[1] == "link 'base': nothing drawn"
    assert notes[2] == ("link 'l1b' <visual> 0: package 'nopkg' is in none of the package dirs (none given); "
                        "drawing its collision shapes")


def test_package_uris_resolve_as_the_loader_resolves_them(tmp_path):
    from chasles.view.shapes import resolve_uri

    (tmp_path / "b" / "pkg" / "m").mkdir(parents=True)
    (tmp_path / "b" / "pkg" / "m" / "x.stl").write_text("solid x\nendsolid x\n")
    dirs = [str(tmp_path / "a"), str(tmp_path / "b")]
    assert resolve_uri("package://pkg/m/x.stl", "/", dirs) == str(tmp_path / "b" / "pkg" / "m" / "x.stl")
    assert resolve_uri("m/x.stl", str(tmp_path / "b" / "pkg"), []) == str(tmp_path / "b" / "pkg" / "m" / "x.stl")
    assert resolve_uri(f"file://{tmp_path}/b/pkg/m/x.stl", "/", []) == str(tmp_path / "b" / "pkg" / "m" / "x.stl")
    with pytest.raises(FileNotFoundError, match="no such file in package 'pkg'"):
        resolve_uri("package://pkg/m/y.stl", "/", dirs)
    with pytest.raises(FileNotFoundError, match=r"package 'other' is in none of the package dirs \('.*/a', '.*/b'\)"):
        resolve_uri("package://other/m/x.stl", "/", dirs)


def test_quaternions_give_back_their_rotations():
    from chasles._command_checks import rotation_from_quaternion
    from chasles.view.app import quaternion_wxyz

    rng = np.random.default_rng(7)
    axes = rng.normal(size=(200, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate([rng.uniform(0, math.pi, 190), [0, 1e-8, math.pi - 1e-8, *[math.pi] * 7]])
    rotations = []
    for axis, angle in zip(axes, angles):
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        rotations.append(np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K)  # Rodrigues
    rotations += [np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1])]
    for R in rotations:
        wxyz = quaternion_wxyz(R)
        np.testing.assert_allclose(rotation_from_quaternion(wxyz), R, atol=1e-14)
        assert abs(np.linalg.norm(wxyz) - 1) < 1e-15 and wxyz[0] >= 0
