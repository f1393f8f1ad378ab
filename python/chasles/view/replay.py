"""Replay of an LCM log in the view: the logged messages handed to the view's own handlers as if
the bus carried them at the log's time t, with a time slider, play/pause at any speed and plots of
the joints, the torques and the tip force on the same clock.

The clock is the logger's receive time (event_utime), the one clock every channel of a log shares:
the plant stamps its physics time and the controller its wall clock, which need not agree.
"""
from __future__ import annotations

import threading
import time
from typing import Optional

import numpy as np

from chasles.logs import LogError, events, read_log

PLOT_WINDOW_S = 5.0  # the plots show the last this many seconds up to t
PLOT_POINTS = 400  # samples per plotted window (step-held from the messages)
PLOT_PERIOD_S = 0.1  # the plots are redrawn at most this often


class Replay:
    def __init__(self, view, path: str, *, speed: float = 1.0, playing: bool = True):
        self.view, self.path = view, path
        handlers = view.handlers()
        times: dict[str, list] = {channel: [] for channel in handlers}
        data: dict[str, list] = {channel: [] for channel in handlers}
        for event in events(path):
            if event.channel in times:
                times[event.channel].append(event.utime)
                data[event.channel].append(event.data)
        heard = [channel for channel in handlers if times[channel]]
        if not heard:
            raise LogError(f"{path}: no message on {', '.join(handlers)} (another --prefix?)")
        self.t0 = min(times[channel][0] for channel in heard)
        self.duration = (max(times[channel][-1] for channel in heard) - self.t0) / 1e6
        self.tracks = {channel: ((np.array(times[channel], np.int64) - self.t0) / 1e6, data[channel], handlers[channel])
                       for channel in heard}
        self.shown = {channel: -1 for channel in heard}
        self.t = 0.0
        self.speed = speed
        self.playing = playing
        self._lock = threading.Lock()
        self._asked: Optional[float] = None  # a time the slider asked for, taken by the next frame
        self._played_from = 0.0  # when Play was last clicked (time.monotonic)
        # Fresh and silent by the log's clock, not the wall's: a paused replay is not a silent bus.
        view.live = False
        view.clock = view.state.clock = view.status.clock = view.truth.clock = lambda: self.t
        self._series = self._read_series(view.prefix)
        self._plotted_t, self._plots_drawn = None, 0.0  # the t the plots show, and when they were sent
        self._slider_t = 0.0  # the t the slider was last set to here
        self._build()
        self.seek(0.0)

    # -- the log's messages at time t --

    def seek(self, t: float) -> None:
        """Hands the view each channel's latest message logged at or before t."""
        self.t = min(max(t, 0.0), self.duration)
        for channel, (times, data, handler) in self.tracks.items():
            i = int(np.searchsorted(times, self.t, side="right")) - 1
            if i >= 0 and i != self.shown[channel]:
                handler(channel, data[i], float(times[i]))
                self.shown[channel] = i

    # -- the plots --

    def _read_series(self, prefix: str) -> dict:
        """{plot title: (times s, (N, k) values, names)} from the log's decoded fields."""
        log = read_log(self.path, channels=[prefix + "STATE", prefix + "STATUS", prefix + "TRUTH"])
        series = {}

        def add(title, channel, values, names):
            if channel in log and values is not None and values.dtype != object and values.ndim == 2:
                t = (np.asarray(log[channel]["event_utime"], np.int64) - self.t0) / 1e6
                series[title] = (t, values.astype(float), names)

        nq = self.view.model.nq
        joints = [f"q{i + 1}" for i in range(nq)]
        state = log.get(prefix + "STATE", {})
        add("joints (rad or m)", prefix + "STATE", state.get("position"), joints)
        add("torques applied (N·m or N)", prefix + "STATE", state.get("effort"), [f"τ{i + 1}" for i in range(nq)])
        forces = []
        for channel, name in ((prefix + "STATUS", "estimated"), (prefix + "TRUTH", "true")):
            wrench = log.get(channel, {}).get("tip_wrench_ext")
            if wrench is not None and wrench.ndim == 2:
                t = (np.asarray(log[channel]["event_utime"], np.int64) - self.t0) / 1e6
                forces.append((t, np.linalg.norm(wrench[:, 3:], axis=1)[:, None], [name]))
        if forces:
            series["tip force |f| (N)"] = forces
        return series

    @staticmethod
    def _held(times: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
        """values step-held at each grid time (NaN before the first)."""
        i = np.searchsorted(times, grid, side="right") - 1
        out = values[np.maximum(i, 0)].copy()
        out[i < 0] = np.nan
        return out

    def _plot_data(self, title: str):
        """The window's columns: the last PLOT_WINDOW_S up to t (from 0 until then), empty after t,
        so that each curve ends where the arm is."""
        start = max(0.0, self.t - PLOT_WINDOW_S)
        end = max(self.t, min(start + PLOT_WINDOW_S, self.duration), start + 1e-3)
        grid = np.linspace(start, end, PLOT_POINTS)
        entry = self._series[title]
        parts = entry if isinstance(entry, list) else [entry]
        columns = [grid]
        for times, values, _ in parts:
            held = self._held(times, values, grid)
            held[grid > self.t] = np.nan
            columns.extend(held[:, k] for k in range(held.shape[1]))
        return tuple(columns)

    # -- the controls --

    def _build(self) -> None:
        gui = self.view.server.gui
        gui.configure_theme(dark_mode=False, show_logo=False, show_share_button=False, control_width="large")
        self.caption_time()
        with gui.add_folder("replay"):
            self.slider = gui.add_slider("time (s)", min=0.0, max=max(self.duration, 1e-3), step=0.001,
                                         initial_value=0.0)
            self.button = gui.add_button("Pause" if self.playing else "Play")
            self.speed_input = gui.add_number("speed (×)", initial_value=self.speed, min=0.01, max=100.0, step=0.01)
        self.slider.on_update(self._on_slider)
        self.button.on_click(self._on_button)
        self.speed_input.on_update(self._on_speed)
        colours = ["#e6550d", "#3182bd", "#31a354", "#756bb1", "#636363", "#e7ba52", "#d6616b", "#17becf"]
        self.plots = {}
        with gui.add_folder("plots"):
            for title in self._series:
                entry = self._series[title]
                names = [n for part in (entry if isinstance(entry, list) else [entry]) for n in part[2]]
                if title.startswith("tip force"):
                    palette = ["#d000c8", "#00aa3c"]  # the arrows' colours: estimated magenta, true green
                else:
                    palette = colours
                series = ({"label": "t (s)"},) + tuple(
                    {"label": name, "stroke": palette[k % len(palette)], "width": 1.5} for k, name in enumerate(names))
                self.plots[title] = gui.add_uplot(self._plot_data(title), series, title=title, aspect=1.6,
                                                  scales={"x": {"time": False}})

    async def _on_slider(self, event) -> None:
        # A coroutine, run on viser's event loop right after it stores the browser's value: a plain
        # callback runs later in viser's thread pool, and the frame's own assignment of the slider
        # (as t advances) could come between and be read instead, losing the browser's seek (seen:
        # Home on a paused replay's slider ignored under load).
        if event.client is None:  # our own assignment, as t advances
            return
        with self._lock:
            self._asked = float(self.slider.value)

    def _on_button(self, event) -> None:
        with self._lock:
            self.playing = not self.playing
            # The log's time runs from the click, not from the frame before it (which would start
            # the play up to a period × the speed ahead).
            self._played_from = time.monotonic()
            if self.playing and self.t >= self.duration:
                self._asked = 0.0  # play again from the start
        self.button.label = "Pause" if self.playing else "Play"

    def _on_speed(self, event) -> None:
        with self._lock:
            self.speed = float(self.speed_input.value)

    def caption_time(self) -> None:
        state = f"playing ×{self.speed:g}" if self.playing else "paused"
        self.view.caption = f"**log** {self.t:.3f} s of {self.duration:.3f} s, {state}"

    # -- the loop --

    def run(self, stop: threading.Event) -> None:
        """Advances t while playing and draws, at most the view's rate a second, until `stop`."""
        last = time.monotonic()
        while not stop.wait(self.view.period):
            now = time.monotonic()
            with self._lock:
                asked, self._asked = self._asked, None
                t = self.t + (now - max(last, self._played_from)) * self.speed if self.playing else self.t
                if asked is not None:
                    t = asked
                if t >= self.duration and self.playing:
                    t, self.playing = self.duration, False
                    self.button.label = "Play"
            last = now
            # The plots cost the browser more than the rest of a frame (three uPlot charts: a seek
            # showed in 108 to 156 ms with them, 27 to 97 without, headless Chromium): a seek's
            # frame goes without them, so that the arm and the panel show the new time first, and
            # they follow in a later frame; at most every PLOT_PERIOD_S (3 × while dragging).
            since = now - self._plots_drawn
            self.show(t, plots=since >= PLOT_PERIOD_S and (asked is None or since >= 3 * PLOT_PERIOD_S),
                      sought=asked is not None)

    def show(self, t: float, plots: bool = True, sought: bool = True) -> None:
        """Draws the log at time t: its messages, the panel's time, the slider and, if `plots`,
        the plots. A time `sought` (not reached by playing) rewrites the panel at once, however
        recently it was: its throttle held a seek's new time back by up to PANEL_PERIOD_S."""
        self.seek(t)
        self.caption_time()
        self.view.draw(panel_now=sought)
        # Only as t moves: the slider has two writers, this and the browser, and a paused replay
        # leaves it to the browser alone.
        if self.t != self._slider_t:
            self.slider.value = round(self.t, 3)
            self._slider_t = self.t
        if plots and self.t != self._plotted_t:
            for title, plot in self.plots.items():
                plot.data = self._plot_data(title)
            self._plotted_t, self._plots_drawn = self.t, time.monotonic()
