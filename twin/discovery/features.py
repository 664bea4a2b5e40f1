"""The dictionary of candidate terms for discovery: features of the measurement's own columns.

Each feature is a :class:`FeatureSpec` (a kind and its parameters) evaluated from time,
temperature, run and power-on time only, so a plugin written from it computes the same column
on any log. Features are computed on block means (``average_s``) inside each run and
interpolated back to the sample times: the temperature is already smoothed over 10 s by the
problem, and a median filter or play operator over 515k samples would cost seconds.

Forms (units in each spec's ``unit``): powers of ΔT = T − 25 °C; the rate R = dT/dt [°C/min],
R², |R|, ΔT·R; first-order lag errors T_τ − T (Ljung, *System Identification*, §2.1);
play-operator offsets p_w(T) − T (Visintin, *Differential Models of Hysteresis*, 1994, ch. III);
exp(−t_on/τ) after each power-on; exp(−s/τ)·ΔT_last after each temperature change (a Maxwell
relaxation, Findley et al., *Creep and Relaxation of Nonlinear Viscoelastic Materials*, ch. 5);
smooth steps ½(1 + tanh((T − Tc)/w)); the short oscillation T − median_w(T) (a median filter
keeps ramps and their corners, so only the controller's limit cycle remains); the limit cycle fitted
in each hold as a sinusoid at the log's own period with a cubic baseline (the median forms take in the
approach or the next ramp when a hold lasts under two periods); slow trends t, t².
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from sim.recursion import first_order_filter

from twin.arrays import run_slices, temperature_rate_c_per_s
from twin.estimation.noise import BlockAverager

T_REF_C = 25.0
LAG_TAUS_S = (30.0, 60.0, 120.0, 300.0, 600.0, 1200.0, 3600.0)
PLAY_WIDTHS_C = (0.5, 1.0, 2.0, 4.0, 8.0)
POWER_ON_TAUS_S = (60.0, 180.0, 600.0, 1800.0, 5400.0)
CHANGE_TAUS_S = (300.0, 1200.0, 3600.0)
STEP_WIDTHS_C = (0.5, 2.0)
STEP_SPACING_C = 5.0
OSC_WINDOWS_S = (300.0, 600.0, 1200.0)
OSC_PERIODS_S = (120.0, 1800.0)  # band searched for the controller's limit cycle
RAMP_MIN_S = 180.0  # a ramp lasts longer than this; shorter excursions of the median are the limit cycle
HOLD_SMOOTH_S = 1200.0  # holds are found on a median this long: the limit cycle's own rate is not a ramp
RATE_THRESHOLD_C_PER_MIN = 0.1  # |dT/dt| below this is a dwell (end of a temperature change)
RATE_SMOOTH_BLOCKS = 6  # dT/dt is smoothed over this many blocks (a minute at 10 s) before differencing


@dataclass(frozen=True)
class FeatureSpec:
    """One candidate term: ``kind`` with its parameters; ``label`` is the printed form.

    Attributes
    ----------
    kind : str
        ``power``, ``rate``, ``lag``, ``play``, ``power_on``, ``since_change``, ``step``, … (module docstring).
    params : tuple of (str, float)
        Its parameters, sorted by name, in each one's unit (``tau_s`` [s], ``width_c`` [°C] …).
    label : str
        The printed form.
    unit : str
        Unit of the feature itself (the coefficient is mg per this unit).
    """

    kind: str
    params: tuple[tuple[str, float], ...] = ()
    label: str = ""
    unit: str = ""  # unit of the feature itself (the coefficient is mg per this unit)

    def p(self, name: str) -> float:
        """One parameter's value.

        Parameters
        ----------
        name : str
            The parameter, e.g. ``tau_s``.

        Returns
        -------
        float
            Its value [the unit its name ends in].
        """
        return dict(self.params)[name]

    def to_dict(self) -> dict:
        """The spec as plain data, ``params`` as a dict (the form a plugin file stores).

        Returns
        -------
        dict
        """
        d = asdict(self)
        d["params"] = dict(self.params)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> FeatureSpec:
        """The spec from :meth:`to_dict`'s data.

        Parameters
        ----------
        d : dict
            ``kind``, and optionally ``params``, ``label``, ``unit``.

        Returns
        -------
        FeatureSpec
        """
        return cls(d["kind"], tuple(sorted(d.get("params", {}).items())), d.get("label", ""), d.get("unit", ""))


@dataclass
class BlockInputs:
    """Block means of the inputs inside each run (the grid every feature is computed on).

    Attributes
    ----------
    time_s, temp_c : np.ndarray
        Block means of time [s] and temperature [°C].
    run : np.ndarray
        Run of each block.
    t_on_s : np.ndarray
        Block means of the time since power-on [s].
    dt_s : float
        Block length [s].
    rate_c_per_min : np.ndarray
        dT/dt of the one-minute smoothed temperature [°C/min], derived.
    """

    time_s: np.ndarray
    temp_c: np.ndarray
    run: np.ndarray
    t_on_s: np.ndarray
    dt_s: float  # block length [s]
    rate_c_per_min: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.rate_c_per_min = _smoothed_rate_c_per_min(self, self.temp_c)


def _smoothed_rate_c_per_min(b: BlockInputs, temp_c: np.ndarray) -> np.ndarray:
    return temperature_rate_c_per_s(b.time_s, temp_c, b.run, smooth_s=RATE_SMOOTH_BLOCKS * b.dt_s) * 60.0


def block_inputs(time_s, temp_c, run_index, t_on_s, average_s: float) -> tuple[BlockInputs, BlockAverager]:
    """Block means of the inputs (blocks of ``average_s`` inside each run) and the averager.

    Parameters
    ----------
    time_s, temp_c : array_like
        Sample times [s] and temperature [°C].
    run_index : array_like
        Run of each sample.
    t_on_s : array_like or None
        Time since power-on [s]; None: time since the first sample.
    average_s : float
        Block length [s].

    Returns
    -------
    BlockInputs
        The inputs on the block grid.
    BlockAverager
        The blocks.
    """
    time_s = np.asarray(time_s, float)
    dt = float(np.median(np.diff(time_s))) if time_s.size > 1 else 1.0
    avg = BlockAverager.build(np.asarray(run_index), int(round(average_s / max(dt, 1e-12))))
    t_on = np.asarray(t_on_s, float) if t_on_s is not None else time_s - time_s[0]
    b = BlockInputs(avg(time_s), avg(np.asarray(temp_c, float)), avg.run_of_block, avg(t_on),
                    float(max(average_s, dt)))
    return b, avg


def _per_run(b: BlockInputs, fn) -> np.ndarray:
    out = np.empty_like(b.temp_c)
    for s in run_slices(b.run):
        out[s] = fn(s)
    return out


def _lag(b: BlockInputs, tau_s: float) -> np.ndarray:
    a = np.exp(-b.dt_s / tau_s)  # exact first-order discretisation, started at equilibrium per run

    def f(s):
        x = b.temp_c[s]
        return first_order_filter(x - x[0], 1 - a, 0.0, a) + x[0] - x
    return _per_run(b, f)


def _play(b: BlockInputs, width_c: float) -> np.ndarray:
    def f(s):
        x = b.temp_c[s]
        y = np.empty_like(x)
        cur = x[0]
        for i, v in enumerate(x):  # blocks only (≤ 10⁵): the plain loop is fast enough here
            cur = min(max(cur, v - width_c), v + width_c)
            y[i] = cur
        return y - x
    return _per_run(b, f)


def _since_change(b: BlockInputs, tau_s: float) -> np.ndarray:
    def f(s):
        t, x, r = b.time_s[s], b.temp_c[s], np.abs(b.rate_c_per_min[s])
        out = np.zeros_like(x)
        moving = r > RATE_THRESHOLD_C_PER_MIN
        start_t, last_change, in_ramp, ramp_start_x = None, 0.0, False, x[0]
        for i in range(x.size):
            if moving[i] and not in_ramp:
                in_ramp, ramp_start_x = True, x[i]
            elif not moving[i] and in_ramp:
                in_ramp, start_t, last_change = False, t[i], x[i] - ramp_start_x
            if start_t is not None and not in_ramp:
                out[i] = last_change * np.exp(-(t[i] - start_t) / tau_s)
        return out
    return _per_run(b, f)


def _running_median(x: np.ndarray, size: int) -> np.ndarray:
    """scipy.ndimage's running median, ends extended; imported here so that a compare without
    ``--discover`` starts without scipy."""
    from scipy.ndimage import median_filter

    return median_filter(x, size=size, mode="nearest")


def _oscillation(b: BlockInputs, window_s: float) -> np.ndarray:
    w = max(3, int(round(window_s / b.dt_s)) | 1)
    return _per_run(b, lambda s: b.temp_c[s] - _running_median(b.temp_c[s], w))


def holds(b: BlockInputs) -> list[slice]:
    """Stretches where the set-point holds: everything but the ramps, a ramp being |dT/dt| of the
    temperature's 20-min running median above :data:`RATE_THRESHOLD_C_PER_MIN` for longer than
    :data:`RAMP_MIN_S` (the limit cycle alone can reach 0.5 °C/min, but not for that long).

    Parameters
    ----------
    b : BlockInputs

    Returns
    -------
    list of slice
        Block ranges of the holds, run by run.
    """
    w = max(3, int(round(HOLD_SMOOTH_S / b.dt_s)) | 1)
    min_ramp = max(1, int(round(RAMP_MIN_S / b.dt_s)))
    median = np.concatenate([_running_median(b.temp_c[s], w) for s in run_slices(b.run)])
    rate = _smoothed_rate_c_per_min(b, median)
    out = []
    for s in run_slices(b.run):
        if s.stop - s.start < 3:
            continue
        moving = np.abs(rate[s]) >= RATE_THRESHOLD_C_PER_MIN
        edges = np.flatnonzero(np.diff(np.r_[0, moving.astype(np.int8), 0]))
        for i, j in zip(edges[::2], edges[1::2]):
            if j - i < min_ramp:
                moving[i:j] = False
        edges = np.flatnonzero(np.diff(np.r_[0, (~moving).astype(np.int8), 0]))
        out += [slice(s.start + i, s.start + j) for i, j in zip(edges[::2], edges[1::2])]
    return out


def _hold_designs(b: BlockInputs, min_s: float) -> list[tuple[slice, np.ndarray]]:
    """Each hold of at least ``min_s`` with its cubic baseline (the approach to the set-point)."""
    out = []
    for h in holds(b):
        t = b.time_s[h]
        if t.size >= 8 and t[-1] - t[0] >= min_s:
            u = (t - t[0]) / (t[-1] - t[0]) * 2 - 1
            out.append((h, np.column_stack([np.ones_like(u), u, u * u, u ** 3])))
    return out


def _sine_fit(b: BlockInputs, period_s: float, designs) -> tuple[np.ndarray, float]:
    """The sinusoid at ``period_s`` fitted with each hold's baseline (``designs`` of
    :func:`_hold_designs`), and the residual sum of squares."""
    out, rss, w = np.zeros_like(b.temp_c), 0.0, 2 * np.pi / period_s
    for h, base in designs:
        t = b.time_s[h]
        A = np.column_stack([base, np.sin(w * t), np.cos(w * t)])
        coef = np.linalg.lstsq(A, b.temp_c[h], rcond=None)[0]
        out[h] = A[:, -2:] @ coef[-2:]
        rss += float(np.sum((b.temp_c[h] - A @ coef) ** 2))
    return out, rss


def _hold_sine(b: BlockInputs, period_s: float) -> np.ndarray:
    """The temperature's sinusoid at ``period_s`` in each hold longer than half a period, fitted
    jointly with a cubic baseline; zero outside holds."""
    return _sine_fit(b, period_s, _hold_designs(b, 0.5 * period_s))[0]


def oscillation_period_s(b: BlockInputs) -> float | None:
    """The period of the temperature's short oscillation in the holds: the one of
    :data:`OSC_PERIODS_S` (log grid) whose per-hold sinusoid + cubic baseline leaves the least
    residual — the generalised Lomb–Scargle periodogram with a polynomial baseline (Zechmeister &
    Kürster, *A&A* 496, 2009), on holds of at least the longest period; None without one.

    Parameters
    ----------
    b : BlockInputs

    Returns
    -------
    float or None
        The period [s], or None without a long enough hold.
    """
    designs = _hold_designs(b, OSC_PERIODS_S[1]) if b.temp_c.size else []
    if not designs:
        return None
    periods = np.geomspace(*OSC_PERIODS_S, 240)
    rss = [_sine_fit(b, p, designs)[1] for p in periods]
    return float(periods[int(np.argmin(rss))])


def block_feature(spec: FeatureSpec, b: BlockInputs) -> np.ndarray:
    """The feature on the block grid.

    Parameters
    ----------
    spec : FeatureSpec
    b : BlockInputs

    Returns
    -------
    np.ndarray
        One value per block [``spec.unit``].

    Raises
    ------
    ValueError
        An unknown feature kind.
    """
    dT, R = b.temp_c - T_REF_C, b.rate_c_per_min
    k = spec.kind
    if k == "power":
        return dT ** int(spec.p("n"))
    if k == "rate":
        return R.copy()
    if k == "rate2":
        return R * R
    if k == "abs_rate":
        return np.abs(R)
    if k == "temp_rate":
        return dT * R
    if k == "lag":
        return _lag(b, spec.p("tau_s"))
    if k == "play":
        return _play(b, spec.p("width_c"))
    if k == "power_on":
        return np.exp(-b.t_on_s / spec.p("tau_s"))
    if k == "since_change":
        return _since_change(b, spec.p("tau_s"))
    if k == "step":
        return 0.5 * (1 + np.tanh((b.temp_c - spec.p("at_c")) / spec.p("width_c")))
    if k == "oscillation":
        return _oscillation(b, spec.p("window_s"))
    if k == "hold_sine":
        return _hold_sine(b, spec.p("period_s"))
    if k == "trend":
        return ((b.time_s - b.time_s[0]) / 3600.0) ** int(spec.p("n"))
    raise ValueError(f"unknown feature kind {k!r}")


def full_rate(values_blocks: np.ndarray, b: BlockInputs, time_s: np.ndarray, run_index: np.ndarray) -> np.ndarray:
    """A block-grid feature interpolated back to the sample times, run by run.

    Parameters
    ----------
    values_blocks : np.ndarray
        The feature per block [its unit].
    b : BlockInputs
    time_s : np.ndarray
        Sample times [s].
    run_index : np.ndarray
        Run of each sample.

    Returns
    -------
    np.ndarray
        The feature per sample [its unit].
    """
    out = np.empty(np.shape(time_s), float)
    runs_full = run_slices(np.asarray(run_index))
    runs_block = run_slices(b.run)
    for sf, sb in zip(runs_full, runs_block):
        out[sf] = np.interp(time_s[sf], b.time_s[sb], values_blocks[sb])
    return out


def feature_full(spec: FeatureSpec, time_s, temp_c, run_index, t_on_s, average_s: float) -> np.ndarray:
    """The feature at the sample times (what a discovered plugin's basis computes).

    Parameters
    ----------
    spec : FeatureSpec
    time_s, temp_c, run_index, t_on_s, average_s
        As for :func:`block_inputs` ([s], [°C], run, [s] or None, [s]).

    Returns
    -------
    np.ndarray
        The feature per sample [``spec.unit``].
    """
    b, _ = block_inputs(time_s, temp_c, run_index, t_on_s, average_s)
    return full_rate(block_feature(spec, b), b, np.asarray(time_s, float), run_index)


def _spec(kind: str, label: str, unit: str, **params: float) -> FeatureSpec:
    return FeatureSpec(kind, tuple(sorted(params.items())), label, unit)


def dictionary(b: BlockInputs) -> list[FeatureSpec]:
    """Every candidate term for this temperature history (steps over its 5–95 % range).

    Parameters
    ----------
    b : BlockInputs

    Returns
    -------
    list of FeatureSpec
        The dictionary searched by :mod:`twin.discovery.search`.
    """
    specs = [_spec("power", f"ΔT^{n}", f"°C^{n}" if n > 1 else "°C", n=n) for n in (1, 2, 3)]
    specs += [_spec("rate", "dT/dt", "°C/min"), _spec("rate2", "(dT/dt)²", "(°C/min)²"),
              _spec("abs_rate", "|dT/dt|", "°C/min"), _spec("temp_rate", "ΔT·dT/dt", "°C²/min")]
    specs += [_spec("lag", f"(T lagged τ={t:g} s − T)", "°C", tau_s=t) for t in LAG_TAUS_S]
    specs += [_spec("play", f"(play_{w:g}°C(T) − T)", "°C", width_c=w) for w in PLAY_WIDTHS_C]
    specs += [_spec("power_on", f"exp(−t_on/{t:g} s)", "1", tau_s=t) for t in POWER_ON_TAUS_S]
    specs += [_spec("since_change", f"ΔT_last·exp(−t_change/{t:g} s)", "°C", tau_s=t) for t in CHANGE_TAUS_S]
    lo, hi = np.percentile(b.temp_c, [5, 95]) if b.temp_c.size else (0.0, 0.0)
    for at in np.arange(np.ceil(lo / STEP_SPACING_C) * STEP_SPACING_C, hi, STEP_SPACING_C / 2):
        specs += [_spec("step", f"step(T > {at:g} °C, w {w:g} °C)", "1", at_c=float(at), width_c=w)
                  for w in STEP_WIDTHS_C]
    specs += [_spec("oscillation", f"(T − median_{w:g}s(T))", "°C", window_s=w) for w in OSC_WINDOWS_S]
    period = oscillation_period_s(b)
    if period is not None:
        specs.append(_spec("hold_sine", f"sine_{period:.0f}s(T) in holds", "°C", period_s=round(period, 1)))
    specs += [_spec("trend", "t" if n == 1 else f"t^{n}", "h" if n == 1 else f"h^{n}", n=n) for n in (1, 2)]
    return specs
