"""python -m chasles.view: the arm live in a browser, or a log replayed (docs/view.md).

  python -m chasles.view --urdf tests/data/panda.urdf --tip panda_hand_tcp \\
      --package-dir tests/data/packages --url 'udpm://239.255.76.67:7667?ttl=0'
  python -m chasles.view run.lcmlog --urdf tests/data/panda.urdf --tip panda_hand_tcp
  python -m chasles.view --urdf tests/data/panda.urdf --tip panda_hand \
      --arm left --prefix LEFT_ --base 0,0.4,0 --arm right --prefix RIGHT_ --base 0,-0.4,0

then open the address it prints (chasles view: http://127.0.0.1:8080).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import signal
import sys
import threading

import numpy as np


def _triple(text: str) -> tuple:
    values = [float(v) for v in text.split(",")]
    if len(values) != 6:
        raise argparse.ArgumentTypeError(f"'{text}': six numbers EYE_X,EYE_Y,EYE_Z,TARGET_X,TARGET_Y,TARGET_Z")
    return (values[:3], values[3:])


def _base(text: str) -> np.ndarray:
    """X,Y,Z[,ROLL,PITCH,YAW]: the arm's base frame in the view's, m and rad (URDF's rpy)."""
    from .shapes import rpy_matrix

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) not in (3, 6) or not np.all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"'{text}': three or six finite numbers X,Y,Z[,ROLL,PITCH,YAW]")
    T = np.eye(4)
    T[:3, 3] = values[:3]
    if len(values) == 6:
        T[:3, :3] = rpy_matrix(values[3:])
    return T


def stop_quietly(server) -> None:
    """viser says "Server stopped" on stdout, where this tool's only line is its address."""
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()


def add_arm_options(p: argparse.ArgumentParser) -> None:
    """The options each arm may give after its --arm NAME (before the first --arm: every arm's)."""
    p.add_argument("--urdf", help="the arm's URDF (the one the controller runs; required)")
    p.add_argument("--tip", help="the chain's tip link (needed when the tree has several leaves)")
    p.add_argument("--prefix", help="the channels' prefix (default CHASLES_)")
    p.add_argument("--protocol", choices=sorted(PROTOCOL_NAMES),
                   help="the arm driver's messages, as the controller's --protocol: chasles (robot_state_t on "
                        "PREFIX STATE, default), drake-iiwa (lcmt_iiwa_status on IIWA_STATUS) or drake-panda "
                        "(lcmt_panda_status on PANDA_STATUS)")
    p.add_argument("--status-channel", help="the driver's status channel (default: the protocol's)")
    p.add_argument("--url", help="LCM's provider URL (default: $LCM_DEFAULT_URL, else LCM's)")
    p.add_argument("--base", type=_base, metavar="X,Y,Z[,R,P,Y]",
                   help="where the arm's base frame is in the view, m and rad (default: the view's origin)")
    p.add_argument("--scene", metavar="FILE",
                   help="a scene file (docs/scene.md) drawn until a scene_t on PREFIX SCENE replaces it")


PROTOCOL_NAMES = ("chasles", "drake-iiwa", "drake-panda")
ARM_DEFAULTS = dict(urdf=None, tip=None, prefix="CHASLES_", protocol="chasles", status_channel=None, url=None,
                    base=None, scene=None)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m chasles.view",
        description="The arm live in a browser: drawn from its URDF where the bus's state puts it, the "
                    "controller's reference as a ghost, the estimated (magenta) and true (green) contact "
                    "forces as arrows, the target and the stiffness frame as axes, the scene and its closest "
                    "pair, the controller's status in the panel. Several arms: one --arm NAME each, followed "
                    "by that arm's options.",
        epilog="example: python -m chasles.view --urdf tests/data/panda.urdf --tip panda_hand_tcp "
               "--package-dir tests/data/packages --url 'udpm://239.255.76.67:7667?ttl=0'; two arms: "
               "... --urdf tests/data/panda.urdf --tip panda_hand --arm left --prefix LEFT_ --base 0,0.4,0 "
               "--arm right --prefix RIGHT_ --base 0,-0.4,0",
    )
    p.add_argument("log", nargs="?", help="an LCM log (lcm-logger's) to replay instead of the live bus")
    p.add_argument("--arm", metavar="NAME",
                   help="starts one arm's options (repeatable): the --urdf, --tip, --prefix, --protocol, "
                        "--status-channel, --url, --base and --scene after it are that arm's; given before "
                        "the first --arm, every arm's that gives none")
    add_arm_options(p)
    p.add_argument("--package-dir", action="append", default=[], metavar="DIR",
                   help="where package://NAME/... meshes are looked for (repeatable; then $ROS_PACKAGE_PATH's folders)")
    p.add_argument("--host", default="127.0.0.1", help="the address to serve on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=int, default=8080, help="the port to serve on (default 8080)")
    p.add_argument("--rate", type=float, default=30.0, help="draws per second at most (default 30)")
    p.add_argument("--force-scale", type=float, default=0.01, help="arrow length per newton, m/N (default 0.01)")
    p.add_argument("--speed", type=float, default=1.0, help="a replay's speed, × real time (default 1)")
    p.add_argument("--paused", action="store_true", help="a replay starts paused at its beginning")
    p.add_argument("--camera", type=_triple, metavar="EX,EY,EZ,TX,TY,TZ",
                   help="the camera's eye and the point it looks at, m, view frame (default: every arm in view)")
    return p


def parse(argv) -> tuple:
    """(the view's options, [each arm's options]). argv is cut at each --arm NAME: what comes
    before is parsed whole (the view's options and every arm's defaults), each arm's part with the
    arm options alone, over those defaults."""
    argv = list(sys.argv[1:] if argv is None else argv)
    cuts = [i for i, a in enumerate(argv) if a == "--arm" or a.startswith("--arm=")]
    p = parser()
    args = p.parse_args(argv[:cuts[0]] if cuts else argv)
    defaults = {key: getattr(args, key) if getattr(args, key) is not None else value
                for key, value in ARM_DEFAULTS.items()}
    if not cuts:
        return args, [argparse.Namespace(name="arm", **defaults)]
    arm_parser = argparse.ArgumentParser(prog="python -m chasles.view ... --arm NAME", argument_default=argparse.SUPPRESS)
    add_arm_options(arm_parser)
    arms = []
    for start, end in zip(cuts, cuts[1:] + [len(argv)]):
        part = argv[start:end]
        if part[0].startswith("--arm="):
            name, rest = part[0][len("--arm="):], part[1:]
        elif len(part) > 1:
            name, rest = part[1], part[2:]
        else:
            p.error("--arm: a name is needed")
        if not re.fullmatch(r"[A-Za-z0-9_-]+", name) or name in ("grid",):
            p.error(f"--arm '{name}': a name of letters, digits, '_' and '-' (and not 'grid')")
        if any(arm.name == name for arm in arms):
            p.error(f"--arm '{name}' is given twice")
        arms.append(argparse.Namespace(name=name, **{**defaults, **vars(arm_parser.parse_args(rest))}))
    return args, arms


def main(argv=None) -> int:
    args, arms = parse(argv)
    if not 1.0 <= args.rate <= 120.0:
        print(f"chasles view: --rate {args.rate}: between 1 and 120 draws per second", file=sys.stderr)
        return 2
    if not 0.01 <= args.speed <= 100.0:
        print(f"chasles view: --speed {args.speed}: between 0.01 and 100 × real time", file=sys.stderr)
        return 2
    for arm in arms:
        if arm.urdf is None:
            print(f"chasles view: {'arm ' + repr(arm.name) + ': ' if len(arms) > 1 else ''}--urdf is required",
                  file=sys.stderr)
            return 2
    if args.log is not None and len(arms) > 1:
        print("chasles view: a replay draws one arm: give no --arm, or one", file=sys.stderr)
        return 2
    import lcm
    import viser

    import chasles
    from chasles._core import read_scene_file
    from chasles.logs import LogError

    from .app import PROTOCOLS, View, default_camera, run, setup_scene
    from .replay import Replay
    from .shapes import load_parts

    package_dirs = list(args.package_dir)
    package_dirs += [d for d in os.environ.get("ROS_PACKAGE_PATH", "").split(":") if d]
    loaded, heard = [], {}
    for arm in arms:
        who = f"arm '{arm.name}': " if len(arms) > 1 else ""
        channel = arm.status_channel or (arm.prefix + "STATE" if arm.protocol == "chasles" else PROTOCOLS[arm.protocol][1])
        for taken in (channel, arm.prefix + "STATUS"):
            other = heard.setdefault((arm.url, taken), arm.name)
            if other != arm.name:
                print(f"chasles view: arms '{other}' and '{arm.name}' both hear {taken}: give each its own "
                      f"--prefix or --status-channel", file=sys.stderr)
                return 2
        try:
            model = chasles.Model.from_urdf(arm.urdf, tip=arm.tip)
            scene = None if arm.scene is None else read_scene_file(arm.scene, package_dirs)
        except chasles.Error as e:
            print(f"chasles view: {who}{e}", file=sys.stderr)
            return 1
        parts, notes = load_parts(arm.urdf, model.link_names, package_dirs)
        loaded.append((arm, model, parts, notes, scene, channel))
    buses = {}
    if args.log is None:
        for arm in arms:
            if arm.url in buses:
                continue
            try:
                buses[arm.url] = lcm.LCM(arm.url) if arm.url else lcm.LCM()
            except (RuntimeError, OSError) as e:
                hint = ""
                if not arm.url or arm.url.startswith("udpm://"):
                    hint = ": is there a multicast route? (inside tools/netns.sh use 'udpm://239.255.76.67:7667?ttl=0')"
                print(f"chasles view: cannot start LCM{' on ' + arm.url if arm.url else ''} ({e}){hint}", file=sys.stderr)
                return 1
    try:
        # viser prints a banner of its own on stdout; the one line below is this tool's.
        with contextlib.redirect_stdout(io.StringIO()):
            server = viser.ViserServer(host=args.host, port=args.port, label="chasles view", verbose=False)
    except OSError as e:
        print(f"chasles view: cannot serve on {args.host}:{args.port} ({e})", file=sys.stderr)
        return 1
    server.gui.configure_theme(dark_mode=False, show_logo=False, show_share_button=False)
    if args.camera is None:
        origins = [(np.eye(4) if arm.base is None else arm.base) @ T
                   for arm, model, *_ in loaded for T in model.link_poses(np.zeros(model.nq))]
        camera = default_camera([T[:3, 3] for T in origins])
    else:
        camera = args.camera
    setup_scene(server, camera)
    views = []
    for arm, model, parts, notes, scene, channel in loaded:
        title = f"{arm.name} ({arm.prefix}, {arm.protocol})" if len(arms) > 1 else None
        views.append(View(server, model, parts, notes, name=arm.name, prefix=arm.prefix, protocol=arm.protocol,
                          state_channel=channel, base=arm.base, scene=scene, scene_source=arm.scene or "",
                          title=title, rate=args.rate, force_scale=args.force_scale))
    replay = None
    if args.log is not None:
        try:
            replay = Replay(views[0], args.log, speed=args.speed, playing=not args.paused)
        except (LogError, OSError) as e:
            print(f"chasles view: {e}", file=sys.stderr)
            stop_quietly(server)
            return 1
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    # viser may have moved to the next free port when the one asked for was taken.
    print(f"chasles view: http://{args.host}:{server.get_port()}", flush=True)
    try:
        if replay is not None:
            replay.run(stop)
        else:
            run([(view, buses[arm.url]) for view, arm in zip(views, arms)], stop)
    finally:
        stop_quietly(server)
    return 0


if __name__ == "__main__":
    sys.exit(main())
