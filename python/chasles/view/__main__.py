"""python -m chasles.view: the arm live in a browser, or a log replayed (docs/view.md).

  python -m chasles.view --urdf tests/data/panda.urdf --tip panda_hand_tcp \\
      --package-dir tests/data/packages --url 'udpm://239.255.76.67:7667?ttl=0'
  python -m chasles.view run.lcmlog --urdf tests/data/panda.urdf --tip panda_hand_tcp

then open the address it prints (chasles view: http://127.0.0.1:8080).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import signal
import sys
import threading


def _triple(text: str) -> tuple:
    values = [float(v) for v in text.split(",")]
    if len(values) != 6:
        raise argparse.ArgumentTypeError(f"'{text}': six numbers EYE_X,EYE_Y,EYE_Z,TARGET_X,TARGET_Y,TARGET_Z")
    return (values[:3], values[3:])


def stop_quietly(server) -> None:
    """viser says "Server stopped" on stdout, where this tool's only line is its address."""
    with contextlib.redirect_stdout(io.StringIO()):
        server.stop()


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m chasles.view",
        description="The arm live in a browser: drawn from its URDF where the bus's robot_state_t puts "
                    "it, the controller's reference as a ghost, the estimated (magenta) and true "
                    "(green) contact forces as arrows, the controller's status in the panel.",
        epilog="example: python -m chasles.view --urdf tests/data/panda.urdf --tip panda_hand_tcp "
               "--package-dir tests/data/packages --url 'udpm://239.255.76.67:7667?ttl=0'",
    )
    p.add_argument("log", nargs="?", help="an LCM log (lcm-logger's) to replay instead of the live bus")
    p.add_argument("--urdf", required=True, help="the arm's URDF (the one the controller runs)")
    p.add_argument("--tip", help="the chain's tip link (needed when the tree has several leaves)")
    p.add_argument("--prefix", default="CHASLES_", help="the channels' prefix (default CHASLES_)")
    p.add_argument("--url", help="LCM's provider URL (default: $LCM_DEFAULT_URL, else LCM's)")
    p.add_argument("--package-dir", action="append", default=[], metavar="DIR",
                   help="where package://NAME/... meshes are looked for (repeatable; then $ROS_PACKAGE_PATH's folders)")
    p.add_argument("--host", default="127.0.0.1", help="the address to serve on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=int, default=8080, help="the port to serve on (default 8080)")
    p.add_argument("--rate", type=float, default=30.0, help="draws per second at most (default 30)")
    p.add_argument("--force-scale", type=float, default=0.01, help="arrow length per newton, m/N (default 0.01)")
    p.add_argument("--speed", type=float, default=1.0, help="a replay's speed, × real time (default 1)")
    p.add_argument("--paused", action="store_true", help="a replay starts paused at its beginning")
    p.add_argument("--camera", type=_triple, metavar="EX,EY,EZ,TX,TY,TZ",
                   help="the camera's eye and the point it looks at, m, base frame (default: the arm in view)")
    return p


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    if not 1.0 <= args.rate <= 120.0:
        print(f"chasles view: --rate {args.rate}: between 1 and 120 draws per second", file=sys.stderr)
        return 2
    if not 0.01 <= args.speed <= 100.0:
        print(f"chasles view: --speed {args.speed}: between 0.01 and 100 × real time", file=sys.stderr)
        return 2
    import lcm
    import viser

    import chasles
    from chasles.logs import LogError

    from .app import View
    from .replay import Replay
    from .shapes import load_parts

    try:
        model = chasles.Model.from_urdf(args.urdf, tip=args.tip)
    except chasles.Error as e:
        print(f"chasles view: {e}", file=sys.stderr)
        return 1
    package_dirs = list(args.package_dir)
    package_dirs += [d for d in os.environ.get("ROS_PACKAGE_PATH", "").split(":") if d]
    parts, notes = load_parts(args.urdf, model.link_names, package_dirs)
    lc = None
    if args.log is None:
        try:
            lc = lcm.LCM(args.url) if args.url else lcm.LCM()
        except (RuntimeError, OSError) as e:
            hint = ""
            if not args.url or args.url.startswith("udpm://"):
                hint = ": is there a multicast route? (inside tools/netns.sh use 'udpm://239.255.76.67:7667?ttl=0')"
            print(f"chasles view: cannot start LCM{' on ' + args.url if args.url else ''} ({e}){hint}", file=sys.stderr)
            return 1
    try:
        # viser prints a banner of its own on stdout; the one line below is this tool's.
        with contextlib.redirect_stdout(io.StringIO()):
            server = viser.ViserServer(host=args.host, port=args.port, label="chasles view", verbose=False)
    except OSError as e:
        print(f"chasles view: cannot serve on {args.host}:{args.port} ({e})", file=sys.stderr)
        return 1
    server.gui.configure_theme(dark_mode=False, show_logo=False, show_share_button=False)
    view = View(server, model, parts, notes, prefix=args.prefix, rate=args.rate,
                force_scale=args.force_scale, camera=args.camera)
    replay = None
    if args.log is not None:
        try:
            replay = Replay(view, args.log, speed=args.speed, playing=not args.paused)
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
            view.run(lc, stop)
    finally:
        stop_quietly(server)
    return 0


if __name__ == "__main__":
    sys.exit(main())
