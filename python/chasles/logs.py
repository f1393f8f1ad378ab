"""LCM logs of a run (lcm-logger's files) read into numpy arrays.

    from chasles.logs import read_log
    log = read_log("run.lcmlog")
    status = log["CHASLES_STATUS"]
    status["utime"]          # (N,) µs, the controller's clock
    status["tip_position"]   # (N, 3) m, base frame
    status["q"]              # (N, n) rad or m

Each message is decoded by its fingerprint (its first 8 bytes) as one of chasles's or Drake's
types (chasles.lcmtypes), whatever its channel; the fields keep the message's names and units
(lcmtypes/*.lcm). The file is framed by this module rather than by lcm.EventLog, which ends
silently at a cut-short event: here damage is an error naming the file and byte offset.
"""
from __future__ import annotations

import dataclasses
import struct
from typing import Iterable, Optional

import numpy as np

from chasles import lcmtypes
from chasles._core import Error

#: LCM's log format: each event is this sync word, then the event number, its timestamp (µs),
#: the channel's and the data's lengths (all big-endian), the channel name and the message.
_SYNC = 0xEDA1DA01
_HEADER = struct.Struct(">IqqII")
#: Longer than any channel name LCM sends (its limit is 63 bytes); more is damage, not a name.
_MAX_CHANNEL = 256

#: Every message class, by its packed fingerprint.
TYPES = {
    getattr(lcmtypes, name)._get_packed_fingerprint(): getattr(lcmtypes, name) for name in lcmtypes.__all__
}


class LogError(Error, ValueError):
    """A log that cannot be read: the message names the file, the byte offset and what is wrong. A
    :class:`chasles.Error` and a ``ValueError``."""


class Log(dict):
    """channel → {field: numpy array}; every array's first axis is the message's index.

    Besides the message's own fields, "event_utime" holds the logger's receive time of each
    (µs since the Unix epoch, the logger's clock). Scalars are (N,), fixed arrays (N, k) (or
    (N, 6, 6)), counted arrays (N, n) when every message has the same count, else an object
    array of N arrays; strings are str arrays.
    """

    def __init__(self, path: str):
        super().__init__()
        self.path = path
        #: channel → the type of its messages ("controller_status_t").
        self.types: dict[str, str] = {}
        #: channel → number of messages left out: of no known type, or of another type than the
        #: channel's first.
        self.skipped: dict[str, int] = {}


@dataclasses.dataclass(frozen=True)
class Event:
    """One event of a log, as framed."""

    offset: int  #: byte offset of its sync word in the file
    number: int  #: the logger's event counter
    utime: int  #: the logger's receive time, µs since the Unix epoch
    channel: str
    data: bytes


def events(path: str) -> Iterable[Event]:
    """The events of an LCM log in file order; LogError at a damaged or cut-short event."""
    with open(path, "rb") as f:
        buffer = f.read()
    offset, count = 0, 0
    while offset < len(buffer):
        where = f"{path}: byte {offset}: event #{count}"
        if len(buffer) - offset < _HEADER.size:
            raise LogError(f"{where} is cut short: its header needs {_HEADER.size} bytes and the file ends "
                           f"{len(buffer) - offset} bytes after its start")
        sync, number, utime, channel_length, data_length = _HEADER.unpack_from(buffer, offset)
        if sync != _SYNC:
            raise LogError(f"{where} does not start with LCM's sync word (0x{sync:08x}, not 0x{_SYNC:08x}): "
                           "the file is damaged or not an LCM log")
        if channel_length > _MAX_CHANNEL:
            raise LogError(f"{where} has a channel name of {channel_length} bytes: the file is damaged")
        end = offset + _HEADER.size + channel_length + data_length
        if end > len(buffer):
            raise LogError(f"{where} is cut short: it needs {end - offset} bytes and the file ends "
                           f"{len(buffer) - offset} bytes after its start")
        start = offset + _HEADER.size
        try:
            channel = buffer[start:start + channel_length].decode("utf-8")
        except UnicodeDecodeError:
            raise LogError(f"{where}: the channel name is not UTF-8: the file is damaged") from None
        yield Event(offset, number, utime, channel, buffer[start + channel_length:end])
        offset, count = end, count + 1


def _column(values: list) -> np.ndarray:
    first = values[0]
    if isinstance(first, str):
        return np.array(values, dtype=str)
    if isinstance(first, (list, tuple)):
        lengths = {len(v) for v in values}
        if len(lengths) > 1:
            column = np.empty(len(values), dtype=object)
            column[:] = [np.array(v) for v in values]
            return column
        if first and isinstance(first[0], str):
            return np.array(values, dtype=str).reshape(len(values), len(first))
        return np.array(values, dtype=float).reshape((len(values),) + np.shape(first))
    if isinstance(first, bool):
        return np.array(values, dtype=bool)
    if isinstance(first, int):
        return np.array(values, dtype=np.int64)
    return np.array(values, dtype=float)


def read_log(path: str, channels: Optional[Iterable[str]] = None) -> Log:
    """The messages of an LCM log, channel by channel, as numpy arrays (see Log).

    channels: the channels to read (None: all). A channel's messages are decoded as the type of
    its first known message; messages of no known type are counted in Log.skipped. A damaged or
    cut-short file, or a message whose fingerprint is known but whose bytes do not decode, raises
    LogError naming the file and byte offset.
    """
    wanted = None if channels is None else set(channels)
    messages: dict[str, list] = {}
    stamps: dict[str, list] = {}
    log = Log(path)
    for event in events(path):
        if wanted is not None and event.channel not in wanted:
            continue
        kind = TYPES.get(event.data[:8])
        if kind is None or log.types.setdefault(event.channel, kind.__name__) != kind.__name__:
            log.skipped[event.channel] = log.skipped.get(event.channel, 0) + 1
            continue
        try:
            message = kind.decode(event.data)
        except (ValueError, struct.error, UnicodeDecodeError) as e:
            raise LogError(f"{path}: byte {event.offset}: event #{event.number} on {event.channel} is a "
                           f"{kind.__name__} that does not decode ({e})") from None
        messages.setdefault(event.channel, []).append(message)
        stamps.setdefault(event.channel, []).append(event.utime)
    for channel, received in messages.items():
        kind = type(received[0])
        log[channel] = {"event_utime": np.array(stamps[channel], dtype=np.int64)}
        for field in kind.__slots__:
            log[channel][field] = _column([getattr(m, field) for m in received])
    for channel in list(log.types):
        if channel not in log:
            del log.types[channel]
    return log
