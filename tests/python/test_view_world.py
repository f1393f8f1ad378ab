"""chasles.view's world around the arm, as a person sees it: two arms in one view (a Panda on
chasles's protocol with the prefix LEFT_, an iiwa on Drake's iiwa protocol with the prefix RIGHT_,
each at its own base), the target's and the stiffness frame's axes, the scene and the closest
pair's gap. The view runs as a process, this test publishes real lcm-gen-encoded messages on the
namespace's bus and headless Chromium takes screenshots, as test_view.py does (its helpers are
used here); where things should be is worked out with chasles's FK and the view's camera.

Then, without a browser: a View in this process fed bytes through its handlers (Drake's Panda
status, the target's visibility rule, bad messages) and the CLI's arms.

Needs the test's network namespace (NETNS) for the bus, and Chromium (tools/deps.sh).
"""
from __future__ import annotations

import json
import math
import os
import re
import time

import numpy as np
import pytest

import chasles
from chasles.lcmtypes import (arm_target_t, control_mode_t, controller_status_t, lcmt_iiwa_status,
                              lcmt_panda_status, scene_t)
from test_view import DATA, LCM_URL, Bus, ghost, hue_saturation, shot, state, status
from view_browser import Browser, chromium_path, project, served_view

from chasles.view.app import CAMERA_FOV_DEG

W, H = 960, 720
EYE, TARGET = (2.9, 0.45, 1.4), (0.2, 0.4, 0.45)
# What the page lays over the 3D canvas: Chromium's software-WebGL notice (top left) and the panel
# with its two arms' folders (top right).
OVERLAYS = [(0, 0, 320, 200), (600, 0, W, 560)]

PANDA = os.path.join(DATA, "panda.urdf")
IIWA = os.path.join(DATA, "iiwa14.urdf")
LEFT_MODEL = chasles.Model.from_urdf(PANDA, tip="panda_hand")
RIGHT_MODEL = chasles.Model.from_urdf(IIWA, tip="iiwa_link_ee")
LEFT_BASE, RIGHT_BASE = np.array([0.0, 0.55, 0.0]), np.array([0.0, -0.55, 0.0])
Q_LEFT = np.array([0.4, -0.3, 0.0, -2.0, 0.0, 1.7, 0.8])
Q_LEFT2 = np.array([-0.9, -0.3, 0.0, -2.0, 0.0, 1.7, 0.8])
Q_RIGHT = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
Q_RIGHT2 = np.array([-0.9, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
# The right arm's scene file: a box obstacle in open space in front of it, a plane and a workspace box.
RIGHT_SCENE = {"version": 1,
               "objects": [{"name": "crate", "shape": {"box": {"size": [0.2, 0.2, 0.2]}}, "pose": {"xyz": [0.55, -0.35, 0.1]}}],
               "planes": [{"name": "floor", "normal": [0, 0, 1], "offset": -0.02}],
               "workspace": [{"name": "cell", "pose": {"xyz": [0.4, 0, 0.5]}, "size": [1.2, 1.2, 1.0]}]}


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


def share(image, uv, colour, radius: int = 4) -> float:
    return float(np.mean(colour(disc(image, uv, radius))))


def arm(p):
    """The arm's orange (test_view's), down to the faces this camera sees in deep shade."""
    hue, saturation, value = hue_saturation(p)
    return (hue >= 8) & (hue <= 45) & (saturation > 0.45) & (value > 10)


# The axes' colours (viser's frames: x red, y green, z blue), the clearance segment's yellow and
# red, the scene's greys and the stiffness frame's dark origin, told apart by hue and saturation.
def red(p):
    hue, saturation, _ = hue_saturation(p)
    return ((hue <= 12) | (hue >= 348)) & (saturation > 0.5)


def green(p):
    hue, saturation, _ = hue_saturation(p)
    return (hue >= 90) & (hue <= 150) & (saturation > 0.5)


def blue(p):
    hue, saturation, _ = hue_saturation(p)
    return (hue >= 215) & (hue <= 255) & (saturation > 0.5)


def yellow(p):
    hue, saturation, _ = hue_saturation(p)
    return (hue >= 45) & (hue <= 62) & (saturation > 0.6)


def grey(p):
    _, saturation, value = hue_saturation(p)
    return (saturation < 0.12) & (value > 90) & (value < 215)  # darker than the light background


def dark(p):
    _, saturation, value = hue_saturation(p)
    return (saturation < 0.3) & (value < 90)


def world(base, points) -> np.ndarray:
    return np.asarray(points, float).reshape(-1, 3) + base


def left(points):
    return world(LEFT_BASE, points)


def right(points):
    return world(RIGHT_BASE, points)


@pytest.fixture(scope="module")
def view(tmp_path_factory):
    scene_file = tmp_path_factory.mktemp("scene") / "right.json"
    scene_file.write_text(json.dumps(RIGHT_SCENE))
    with served_view(["--package-dir", os.path.join(DATA, "packages"), "--url", LCM_URL,
                      "--camera", ",".join(str(v) for v in EYE + TARGET),
                      "--arm", "left", "--urdf", PANDA, "--tip", "panda_hand", "--prefix", "LEFT_",
                      "--base", ",".join(map(str, LEFT_BASE)),
                      "--arm", "right", "--urdf", IIWA, "--tip", "iiwa_link_ee", "--prefix", "RIGHT_",
                      "--protocol", "drake-iiwa", "--base", ",".join(map(str, RIGHT_BASE)), "--scene", str(scene_file)],
                     timeout=30) as process:
        yield process


@pytest.fixture(scope="module")
def page(view):
    assert chromium_path(), "chromium not found (tools/deps.sh installs chasles_packages_view)"
    browser = Browser(W, H)
    try:
        browser.open(view.url)
        browser.wait_text(r"no status", timeout=20)
        yield browser
    finally:
        browser.close()


@pytest.fixture(scope="module")
def bus():
    seat = Bus()
    yield seat
    seat.stop()


def iiwa_status(measured, commanded, utime: int) -> lcmt_iiwa_status:
    m = lcmt_iiwa_status()
    m.utime, m.num_joints = utime, len(measured)
    m.joint_position_measured, m.joint_position_commanded = list(map(float, measured)), list(map(float, commanded))
    zeros = [0.0] * len(measured)
    m.joint_velocity_estimated = m.joint_torque_measured = m.joint_torque_commanded = m.joint_torque_external = zeros
    m.joint_position_ipo = [math.nan] * len(measured)  # as the real driver sends it without FRI's interpolator
    return m


def left_status(q, ticks: int, state=controller_status_t.RUNNING, law=control_mode_t.JOINT_IMPEDANCE,
                pair="", points=((0, 0, 0), (0, 0, 0)), slowed_by="") -> controller_status_t:
    m = status(q, q, ticks)
    m.tip_position = list(LEFT_MODEL.fk(q)[:3, 3])
    m.state, m.law = state, law
    m.clearance_pair, m.clearance_points, m.clearance_slowed_by = pair, [list(map(float, p)) for p in points], slowed_by
    m.clearance_distance = float(np.linalg.norm(np.subtract(points[1], points[0]))) if pair else 0.0
    m.clearance_kept = 0.4 if slowed_by else 1.0
    return m


def both(left_seq: int, right_utime: int) -> str:
    """The panel's text once the left arm's state seq and the right arm's status utime are drawn."""
    return rf"(?s)left \(LEFT_, chasles\).*state seq {left_seq},.*right \(RIGHT_, drake-iiwa\).*state utime {right_utime},"


def test_two_arms_each_at_its_base_and_each_moved_by_its_own_channels(page, bus):
    messages = {"LEFT_STATE": state(Q_LEFT, 11), "IIWA_STATUS": iiwa_status(Q_RIGHT, Q_RIGHT, 5001)}
    bus.send_until(page, messages, both(11, 5001))
    first = shot(page, "two_arms")
    # Every chain link's origin above the base, of each arm, where FK from its own base puts it.
    for model, base, q, image in ((LEFT_MODEL, LEFT_BASE, Q_LEFT, first), (RIGHT_MODEL, RIGHT_BASE, Q_RIGHT, first)):
        for name, uv in zip(model.link_names[2:], screen(world(base, model.link_poses(q)[2:, :3, 3]))):
            assert share(image, uv, arm, radius=2) > 0.5, f"{name} at {uv.round()}: {image[int(uv[1]), int(uv[0])]}"

    # The iiwa moves on its Drake status; the Panda stays.
    messages = {"LEFT_STATE": state(Q_LEFT, 11), "IIWA_STATUS": iiwa_status(Q_RIGHT2, Q_RIGHT2, 5002)}
    bus.send_until(page, messages, both(11, 5002))
    moved = shot(page, "iiwa_moved")
    # The iiwa's flange (its tip) is on its last link's rim: its wrist, link 7's origin, is inside it.
    right_tip, right_tip2 = screen(right([RIGHT_MODEL.link_poses(q)[-2, :3, 3] for q in (Q_RIGHT, Q_RIGHT2)]))
    left_tip, left_tip2 = screen(left([LEFT_MODEL.fk(Q_LEFT)[:3, 3], LEFT_MODEL.fk(Q_LEFT2)[:3, 3]]))
    assert np.linalg.norm(right_tip - right_tip2) > 60 and np.linalg.norm(left_tip - left_tip2) > 60
    assert share(first, right_tip, arm) > 0.8 and share(first, right_tip2, arm) == 0.0
    assert share(moved, right_tip2, arm) > 0.8 and share(moved, right_tip, arm) == 0.0
    assert share(moved, left_tip, arm) > 0.8

    # The Panda moves on LEFT_STATE; the iiwa stays.
    messages = {"LEFT_STATE": state(Q_LEFT2, 12), "IIWA_STATUS": iiwa_status(Q_RIGHT2, Q_RIGHT2, 5002)}
    bus.send_until(page, messages, both(12, 5002))
    panda_moved = shot(page, "panda_moved")
    assert share(panda_moved, left_tip2, arm) > 0.8 and share(panda_moved, left_tip, arm) == 0.0
    assert share(panda_moved, right_tip2, arm) > 0.8

    # No controller status on RIGHT_STATUS: the iiwa's commanded position is its ghost.
    messages = {"LEFT_STATE": state(Q_LEFT2, 12), "IIWA_STATUS": iiwa_status(Q_RIGHT2, Q_RIGHT, 5003)}
    bus.send_until(page, messages, both(12, 5003))
    with_ghost = shot(page, "iiwa_ghost")
    assert share(with_ghost, right_tip, ghost) > 0.8 and share(with_ghost, right_tip2, arm) > 0.8
    assert share(moved, right_tip, ghost) == 0.0


def rotation(yaw: float, pitch: float) -> np.ndarray:
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    return np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]]) @ np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])


def cartesian_target(p, R) -> arm_target_t:
    from chasles.view.app import quaternion_wxyz

    m = arm_target_t()
    m.utime, m.mode, m.num_joints, m.joint_position = int(time.time() * 1e6), arm_target_t.CARTESIAN, 0, []
    m.tip_position, m.tip_quaternion, m.duration = list(map(float, p)), list(quaternion_wxyz(R)), 2.0
    return m


def test_a_cartesian_target_is_drawn_as_axes_until_the_controller_holds(page, bus):
    # Turned so that each axis shows on the screen well apart from the others (yaw -30°, pitch 30°).
    p, R = np.array([0.3, -0.5, 1.0]), rotation(math.radians(-30), math.radians(30))
    x_tip, y_tip, z_tip = screen(left([p + 0.11 * R[:, k] for k in range(3)]))
    before = shot(page, "before_target")
    drawn = bus.send_until(page, {"LEFT_STATE": state(Q_LEFT2, 61), "LEFT_TARGET": cartesian_target(p, R)},
                           r"target CARTESIAN at \(0\.300, -0\.500, 1\.000\), drawn")
    assert "state seq 61," in drawn
    with_target = shot(page, "with_target")
    # The controller's status: HOLDING, heard after the target (which the bus no longer carries).
    bus.send_until(page, {"LEFT_STATE": state(Q_LEFT2, 62), "LEFT_STATUS": left_status(Q_LEFT2, 6001,
                                                                                        controller_status_t.HOLDING)},
                   r"target CARTESIAN at \(0\.300, -0\.500, 1\.000\), hidden")
    held = shot(page, "target_held")
    for uv, colour in ((x_tip, red), (y_tip, green), (z_tip, blue)):
        assert share(with_target, uv, colour, radius=1) > 0.8, f"{uv.round()}: {with_target[int(uv[1]), int(uv[0])]}"
        assert share(before, uv, colour, radius=2) == 0.0 and share(held, uv, colour, radius=2) == 0.0


def test_the_stiffness_frame_is_drawn_on_the_arm_under_cartesian_impedance(page, bus):
    from chasles.view.app import quaternion_wxyz

    mode = control_mode_t()
    mode.utime, mode.law, mode.num_joints, mode.joint_stiffness, mode.joint_damping = 1, control_mode_t.CARTESIAN_IMPEDANCE, 0, [], []
    mode.damping_ratio, mode.cartesian_stiffness = 1.0, np.diag([50.0] * 3 + [500.0] * 3).tolist()
    offset, turn = np.array([0.0, 0.0, 0.2]), rotation(0.4, 0.0)
    mode.stiffness_frame_position, mode.stiffness_frame_quaternion = list(offset), list(quaternion_wxyz(turn))
    mode.num_posture, mode.nullspace_posture, mode.nullspace_stiffness = 0, [], 0.0
    T = LEFT_MODEL.fk(Q_LEFT2)
    where = T[:3, :3] @ offset + T[:3, 3]  # frame c, fixed in the tip's frame, on the arm at q
    uv = screen(left([where]))[0]
    text = bus.send_until(page, {"LEFT_STATE": state(Q_LEFT2, 71), "LEFT_MODE": mode,
                                 "LEFT_STATUS": left_status(Q_LEFT2, 7001, law=control_mode_t.CARTESIAN_IMPEDANCE)},
                          r"ticks 7001")
    assert "stiffness frame drawn at ({:.3f}, {:.3f}, {:.3f})".format(*where) in text, text
    assert "law cartesian-impedance" in text
    with_frame = shot(page, "stiffness_frame")
    text = bus.send_until(page, {"LEFT_STATE": state(Q_LEFT2, 72), "LEFT_MODE": mode,
                                 "LEFT_STATUS": left_status(Q_LEFT2, 7002, law=control_mode_t.JOINT_IMPEDANCE)},
                          r"ticks 7002")
    assert "stiffness frame" not in text
    without = shot(page, "stiffness_frame_gone")
    assert share(with_frame, uv, dark, radius=2) > 0.8, with_frame[int(uv[1]), int(uv[0])]
    assert share(without, uv, dark, radius=3) == 0.0


def box_scene(name: str, centre, size, version: int = scene_t.VERSION) -> scene_t:
    m = scene_t()
    m.version, m.utime, m.num_objects = version, 1, 1
    m.object_name, m.object_kind, m.object_size = [name], [scene_t.BOX], [list(map(float, size))]
    m.object_position, m.object_quaternion = [list(map(float, centre))], [[1.0, 0.0, 0.0, 0.0]]
    m.object_clearance, m.object_num_vertices = [[0.01, 0.1]], [0]
    m.num_vertices, m.vertices, m.num_planes, m.num_boxes = 0, [], 0, 0
    for name in ("plane_name", "plane_normal", "plane_offset", "plane_num_links", "plane_clearance", "plane_links",
                 "box_name", "box_position", "box_quaternion", "box_size", "box_num_links", "box_clearance", "box_links"):
        setattr(m, name, [])
    m.num_plane_links = m.num_box_links = 0
    return m


def test_the_scene_is_drawn_from_its_file_and_its_message_and_a_refused_one_is_said(view, page, bus):
    # The right arm's --scene file: its box obstacle, from the first frame on.
    text = page.wait_text(r"scene: 1 object, 1 plane, 1 workspace box \(.*right\.json\)")
    crate = screen(right([[0.55, -0.35, 0.1]]))[0]
    table = screen(left([[0.5, -0.35, 0.12]]))[0]
    before = shot(page, "scene_before")
    assert share(before, crate, grey) > 0.8, before[int(crate[1]), int(crate[0])]
    assert share(before, table, grey) == 0.0
    # The left arm's scene_t: a 0.2 m box obstacle, where the controller's reader puts it.
    text = bus.send_until(page, {"LEFT_SCENE": box_scene("table", (0.5, -0.35, 0.12), (0.2, 0.2, 0.2))},
                          r"scene: 1 object, 0 planes, 0 workspace boxes \(LEFT_SCENE\)")
    # A new mesh takes the page a few frames more than the panel's text (viser's client builds it):
    # screenshots until it shows, for at most 5 s.
    deadline = time.monotonic() + 5
    while share(drawn := shot(page, "scene_message"), table, grey) <= 0.8 and time.monotonic() < deadline:
        page.frames(3)
    assert share(drawn, table, grey) > 0.8, drawn[int(table[1]), int(table[0])]
    # Refused by the controller's rules: said with its reason; the scene drawn stays.
    said = "LEFT_SCENE: refused (version 2; this receiver reads version 1); the scene drawn is kept"
    text = bus.send_until(page, {"LEFT_SCENE": box_scene("far", (0.5, 0.35, 0.12), (0.2, 0.2, 0.2), version=2)},
                          re.escape(said))
    assert "scene: 1 object, 0 planes, 0 workspace boxes (LEFT_SCENE)" in text
    kept = shot(page, "scene_refused")
    assert share(kept, table, grey) > 0.8
    said_size = "LEFT_SCENE: refused (object 0 'thin': "
    bus.send_until(page, {"LEFT_SCENE": box_scene("thin", (0.5, 0.35, 0.12), (0.2, -0.2, 0.2))}, re.escape(said_size))
    view.expected_notes += [said, said_size]
    bus.stop()


def test_the_closest_pair_is_a_segment_red_while_it_slows_the_motion(page, bus):
    a, b = np.array([0.3, -0.45, 0.35]), np.array([0.3, -0.45, 0.6])
    middle = screen(left([(a + b) / 2]))[0]
    pair = "panda_hand/0 and table"
    text = bus.send_until(page, {"LEFT_STATE": state(Q_LEFT2, 81),
                                 "LEFT_STATUS": left_status(Q_LEFT2, 8001, pair=pair, points=(a, b))}, r"ticks 8001")
    assert f"clearance 0.250 m: {pair}" in text and "slowed by" not in text
    gap = shot(page, "clearance")
    text = bus.send_until(page, {"LEFT_STATE": state(Q_LEFT2, 82),
                                 "LEFT_STATUS": left_status(Q_LEFT2, 8002, pair=pair, points=(a, b), slowed_by=pair)},
                          r"ticks 8002")
    assert f"clearance 0.250 m: {pair}, slowed by this pair (kept 40 %)" in text
    slowing = shot(page, "clearance_slowing")
    text = bus.send_until(page, {"LEFT_STATE": state(Q_LEFT2, 83), "LEFT_STATUS": left_status(Q_LEFT2, 8003)},
                          r"ticks 8003")
    assert "clearance" not in text
    none = shot(page, "clearance_none")
    assert share(gap, middle, yellow, radius=1) > 0.8, gap[int(middle[1]), int(middle[0])]
    assert share(slowing, middle, red, radius=1) > 0.8, slowing[int(middle[1]), int(middle[0])]
    assert share(gap, middle, red, radius=2) == 0.0 and share(slowing, middle, yellow, radius=2) == 0.0
    assert share(none, middle, yellow, radius=2) == 0.0 and share(none, middle, red, radius=2) == 0.0


def test_bad_messages_on_the_new_channels_are_said_and_skipped(view, page, bus):
    bus.send_until(page, {"LEFT_STATE": state(Q_LEFT2, 91), "IIWA_STATUS": iiwa_status(Q_RIGHT, Q_RIGHT, 9001)},
                   both(91, 9001))
    nan_target = cartesian_target((0.3, math.nan, 1.0), np.eye(3))
    bad_mode = control_mode_t()
    bad_mode.law, bad_mode.stiffness_frame_quaternion = control_mode_t.CARTESIAN_IMPEDANCE, [2.0, 0.0, 0.0, 0.0]
    bad_mode.joint_stiffness = bad_mode.joint_damping = bad_mode.nullspace_posture = []
    cases = [("IIWA_STATUS", iiwa_status(Q_RIGHT2[:6], Q_RIGHT2[:6], 9002),
              "IIWA_STATUS: joint_position_measured has 6 entries, the model has 7 joints"),
             ("IIWA_STATUS", iiwa_status(np.where(np.arange(7) == 3, math.inf, Q_RIGHT2), Q_RIGHT2, 9003),
              "IIWA_STATUS: joint_position_measured[3] is inf"),
             ("IIWA_STATUS", state(Q_RIGHT2, 9004), "IIWA_STATUS: a message that is no lcmt_iiwa_status"),
             ("LEFT_TARGET", nan_target, "LEFT_TARGET: a pose field is not finite"),
             ("LEFT_TARGET", b"not a target", "LEFT_TARGET: a message that is no arm_target_t"),
             ("LEFT_MODE", bad_mode, "LEFT_MODE: the stiffness frame: its quaternion's norm is 2, not 1")]
    for channel, message, said in cases:
        text = bus.send_until(page, {channel: message}, re.escape(said))
        assert re.search(both(91, 9001), text), text  # the last good ones are still the ones drawn
    bus.send_until(page, {"IIWA_STATUS": iiwa_status(Q_RIGHT2, Q_RIGHT2, 9005)}, both(91, 9005))
    image = shot(page, "after_bad_world")
    right_tip2 = screen(right([RIGHT_MODEL.link_poses(Q_RIGHT2)[-2, :3, 3]]))[0]
    assert share(image, right_tip2, arm) > 0.8
    assert view.poll() is None
    view.expected_notes += [said for _, _, said in cases]


# -- without a browser: a View in this process, fed bytes through its handlers ---------------------

@pytest.fixture(scope="module")
def server():
    import contextlib
    import io

    import viser

    with contextlib.redirect_stdout(io.StringIO()):
        s = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield s
    with contextlib.redirect_stdout(io.StringIO()):
        s.stop()


def test_a_drake_panda_status_places_the_arm_and_its_desired_position_is_the_ghost(server):
    from chasles.view.app import View

    said = []
    view = View(server, LEFT_MODEL, [], [], name="panda", prefix="P_", protocol="drake-panda", say=said.append)
    assert set(view.handlers()) == {"PANDA_STATUS", "P_STATUS", "P_TRUTH", "P_TARGET", "P_TIP_SETPOINT", "P_MODE",
                                    "P_SCENE"}
    m = lcmt_panda_status()
    m.utime, m.num_joints = 1234, 7
    m.joint_position, m.joint_position_desired = list(Q_LEFT), list(Q_LEFT2)
    for name in ("joint_velocity", "joint_velocity_desired", "joint_acceleration_desired", "joint_torque",
                 "joint_torque_desired", "joint_torque_external"):
        setattr(m, name, [0.0] * 7)
    view.handlers()["PANDA_STATUS"]("PANDA_STATUS", m.encode())
    view.draw()
    np.testing.assert_array_equal(view.q, Q_LEFT)
    assert view.ghost_root.visible and np.array_equal(view._posed[id(view.ghost)], Q_LEFT2)
    assert view.state_seq == 1234 and said == []
    # The desired position back on q: no ghost. A controller status, once heard, is the ghost's source.
    m.utime, m.joint_position_desired = 1235, list(Q_LEFT)
    view.handlers()["PANDA_STATUS"]("PANDA_STATUS", m.encode())
    view.draw()
    assert not view.ghost_root.visible
    view.handlers()["P_STATUS"]("P_STATUS", left_status(Q_LEFT, 1).encode())
    m.utime, m.joint_position_desired = 1236, list(Q_LEFT2)
    view.handlers()["PANDA_STATUS"]("PANDA_STATUS", m.encode())
    view.draw()
    assert not view.ghost_root.visible and view.state_seq == 1236
    # Its desired position not finite: the status is skipped, as the controller refuses it.
    m.utime, m.joint_position_desired = 1237, [math.nan] * 7
    view.handlers()["PANDA_STATUS"]("PANDA_STATUS", m.encode())
    view.draw()
    assert view.state_seq == 1236
    assert said == ["chasles view: PANDA_STATUS: joint_position_desired[0] is nan: messages like it skipped"]


def test_a_target_is_drawn_until_a_status_after_it_says_the_arm_no_longer_runs_toward_it(server):
    from chasles.lcmtypes import tip_setpoint_t
    from chasles.view.app import GOAL_ANSWER_S, View

    view = View(server, LEFT_MODEL, [], [], name="goals", prefix="G_", say=lambda text: None)
    feed = view.handlers()

    def hear(channel, message, when):
        feed[channel](channel, message.encode(), when)
        view.draw()

    hear("G_STATE", state(Q_LEFT, 1), 0.0)
    hold = arm_target_t()
    hold.mode, hold.num_joints, hold.joint_position = arm_target_t.HOLD, 0, []
    hear("G_TARGET", hold, 1.0)
    assert not view.goal_shown() and not view.target_frame.visible
    joint = arm_target_t()
    joint.mode, joint.num_joints, joint.joint_position, joint.duration = arm_target_t.JOINT, 7, list(Q_LEFT2), 1.0
    hear("G_TARGET", joint, 2.0)
    assert view.target_frame.visible
    np.testing.assert_allclose(view._pointed[id(view.target_frame)][0], LEFT_MODEL.fk(Q_LEFT2)[:3, 3], atol=1e-12)
    # A status too soon after it to have answered it, HOLDING: still drawn.
    hear("G_STATUS", left_status(Q_LEFT, 2, controller_status_t.HOLDING), 2.0 + GOAL_ANSWER_S / 2)
    assert view.target_frame.visible
    hear("G_STATUS", left_status(Q_LEFT, 3, controller_status_t.RUNNING), 2.0 + 2 * GOAL_ANSWER_S)
    assert view.target_frame.visible
    # The move over: hidden, and it stays hidden when the arm runs again (toward something else).
    hear("G_STATUS", left_status(Q_LEFT2, 4, controller_status_t.HOLDING), 3.5)
    assert not view.target_frame.visible
    hear("G_STATUS", left_status(Q_LEFT2, 5, controller_status_t.RUNNING), 3.6)
    assert not view.target_frame.visible
    # A tip setpoint: drawn while the status streams, hidden when the stream ends.
    setpoint = tip_setpoint_t()
    setpoint.position, setpoint.quaternion, setpoint.twist = [0.4, 0.1, 0.5], [1.0, 0.0, 0.0, 0.0], [0.0] * 6
    hear("G_TIP_SETPOINT", setpoint, 4.0)
    assert view.target_frame.visible and view._pointed[id(view.target_frame)][0] == (0.4, 0.1, 0.5)
    streaming = left_status(Q_LEFT2, 6)
    streaming.streaming = True
    hear("G_STATUS", streaming, 4.5)
    assert view.target_frame.visible
    hear("G_STATUS", left_status(Q_LEFT2, 7), 4.6)  # RUNNING but no longer streaming
    assert not view.target_frame.visible


def test_the_command_line_gives_each_arm_its_options_over_the_shared_ones():
    from chasles.view.__main__ import parse

    args, arms = parse(["--urdf", "a.urdf", "--port", "0"])
    assert args.port == 0 and [a.name for a in arms] == ["arm"]
    assert (arms[0].urdf, arms[0].prefix, arms[0].protocol, arms[0].base) == ("a.urdf", "CHASLES_", "chasles", None)
    args, arms = parse(["--urdf", "a.urdf", "--tip", "hand", "--url", "udpm://x", "--arm", "left", "--prefix", "LEFT_",
                        "--base", "0,0.5,0", "--arm=right", "--urdf", "b.urdf", "--protocol", "drake-iiwa",
                        "--base", "1,2,3,0,0,1.5707963267948966", "--scene", "s.json"])
    left_arm, right_arm = arms
    assert (left_arm.name, left_arm.urdf, left_arm.tip, left_arm.prefix, left_arm.url) == ("left", "a.urdf", "hand",
                                                                                           "LEFT_", "udpm://x")
    np.testing.assert_array_equal(left_arm.base[:3, 3], [0, 0.5, 0])
    assert (right_arm.urdf, right_arm.tip, right_arm.prefix, right_arm.protocol, right_arm.scene) == (
        "b.urdf", "hand", "CHASLES_", "drake-iiwa", "s.json")
    np.testing.assert_allclose(right_arm.base, [[0, -1, 0, 1], [1, 0, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]], atol=1e-15)
    for argv in (["--arm", "a", "--urdf", "x", "--arm", "a"], ["--arm"], ["--arm", "a b"],
                 ["--arm", "a", "--port", "1"], ["--arm", "a", "--base", "1,2"]):
        with pytest.raises(SystemExit):
            parse(argv)
