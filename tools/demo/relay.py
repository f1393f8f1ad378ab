"""A byte relay between a TCP port and a Unix socket, for tools/demo.sh's view: the demo runs in a
private network namespace (its LCM multicast must stay there), so the view serves on that
namespace's loopback, which a browser on this machine cannot reach. A Unix socket is a file, seen
from both sides: outside, this relay listens on the host's port and forwards to the socket; inside,
another forwards the socket's connections to the view's port.

  python3 tools/demo/relay.py tcp:HOST:PORT unix:PATH      (outside: PORT 0 picks a free one)
  python3 tools/demo/relay.py unix:PATH tcp:127.0.0.1:PORT  (inside)

Once it listens it prints one line, `relay: listening on ADDRESS` (the port it took), and relays
until SIGTERM or SIGINT.
"""
from __future__ import annotations

import asyncio
import os
import signal
import sys


def parse(text: str):
    kind, _, rest = text.partition(":")
    if kind == "unix" and rest:
        return ("unix", rest)
    if kind == "tcp" and rest.count(":") == 1:
        host, port = rest.split(":")
        return ("tcp", host, int(port))
    raise SystemExit(f"relay: '{text}': tcp:HOST:PORT or unix:PATH")


async def pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    try:
        while data := await reader.read(65536):
            writer.write(data)
            await writer.drain()
    except (ConnectionError, OSError):
        pass
    finally:
        writer.close()


async def main(listen, to) -> None:
    async def serve(client_reader, client_writer):
        try:
            if to[0] == "unix":
                reader, writer = await asyncio.open_unix_connection(to[1])
            else:
                reader, writer = await asyncio.open_connection(to[1], to[2])
        except OSError:  # the other side is not up yet (or has gone): this connection fails, the next may not
            client_writer.close()
            return
        await asyncio.gather(pipe(client_reader, writer), pipe(reader, client_writer))

    if listen[0] == "unix":
        if os.path.exists(listen[1]):
            os.unlink(listen[1])
        server = await asyncio.start_unix_server(serve, listen[1])
        address = listen[1]
    else:
        server = await asyncio.start_server(serve, listen[1], listen[2])
        address = "{}:{}".format(*server.sockets[0].getsockname()[:2])
    print(f"relay: listening on {address}", flush=True)
    stop = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        asyncio.get_running_loop().add_signal_handler(sig, stop.set)
    async with server:
        await stop.wait()
    if listen[0] == "unix":
        os.unlink(listen[1])


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    try:
        asyncio.run(main(parse(sys.argv[1]), parse(sys.argv[2])))
    except OSError as e:
        raise SystemExit(f"relay: cannot listen on {sys.argv[1]} ({e})")
