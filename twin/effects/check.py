"""Conformance checks any effect must pass, built-in or plugin: :func:`check_effect`."""

from __future__ import annotations

import numpy as np

from twin.effects.base import Effect, EffectInputs
from twin.effects.registry import Composition
from twin.errors import ModelError


class EffectCheckError(ModelError):
    """An effect class breaks the contract of :class:`~twin.effects.base.Effect`."""


def conformance_inputs(n: int = 20000, dt_s: float = 1.0, seed: int = 0) -> EffectInputs:
    """A test-plan-like input: ramps up and down at two rates, a ±1 g tumble, a power cycle.

    Parameters
    ----------
    n : int
        Number of samples.
    dt_s : float
        Sample interval [s].
    seed : int
        Seed of the thermometer noise (σ 0.01 °C).

    Returns
    -------
    EffectInputs
        Every input filled, one run.
    """
    t = np.arange(n) * dt_s
    temp = 25 + 30 * np.sin(2 * np.pi * t / (n * dt_s / 2.5)) * np.minimum(1, t / 2000)
    rng = np.random.default_rng(seed)
    applied = np.where((t // 1500) % 2 == 0, 1.0, -1.0)
    since = t - np.where(t >= n * dt_s / 2, n * dt_s / 2, 0)
    return EffectInputs(time_s=t, die_c=temp, thermometer_c=temp + rng.normal(0, 0.01, n), applied_g=applied,
                        run_index=np.zeros(n, np.int16), time_since_power_on_s=since)


def _outputs(effect: Effect, inputs: EffectInputs) -> np.ndarray:
    if effect.slot == "temperature":
        return effect.die_temperature(inputs)
    return effect.contribution(inputs).output_g(inputs.applied_g)


def _fail(cls: type[Effect], what: str) -> None:
    raise EffectCheckError(f"effect {getattr(cls, 'name', cls.__name__)!r}: {what}")


def check_parameters(cls: type[Effect]) -> None:
    """Every parameter has a unit, a source, a role, a default inside bounds; grids inside bounds.

    Parameters
    ----------
    cls : type of Effect
        The effect class checked.
    """
    for p in cls.parameters:
        if not (p.unit and p.source):
            _fail(cls, f"parameter {p.name!r} needs a unit and a source")
        lo, hi = p.bounds
        if not (lo <= p.default <= hi and lo < hi):
            _fail(cls, f"parameter {p.name!r}: default {p.default:g} not inside bounds [{lo:g}, {hi:g}]")
        if p.role not in ("amplitude", "nonlinear", "fixed"):
            _fail(cls, f"parameter {p.name!r}: role {p.role!r} is not amplitude, nonlinear or fixed")
        if p.role == "nonlinear" and not all(lo <= v <= hi for v in p.grid):
            _fail(cls, f"parameter {p.name!r}: screening grid outside its bounds")
    if not (cls.grid() and all(set(g) == set(cls.nonlinear_names()) for g in cls.grid())):
        _fail(cls, "grid() must cover every nonlinear parameter")


def check_effect_outputs(cls: type[Effect], inputs: EffectInputs) -> None:
    """Finite outputs of the right shape; the contribution is Σ amplitude × basis.

    Parameters
    ----------
    cls : type of Effect
        The effect class checked (at its defaults).
    inputs : EffectInputs
        Inputs to evaluate it on.
    """
    effect = cls()
    out = _outputs(effect, inputs)
    if np.shape(out) != inputs.time_s.shape or not np.all(np.isfinite(out)):
        _fail(cls, "output must be finite and one value per sample")
    basis = effect.basis(inputs)
    if not set(basis) <= set(effect.amplitude_names()):
        _fail(cls, f"basis keys {sorted(set(basis) - set(effect.amplitude_names()))} are not amplitude parameters")
    total = sum((effect.values[k] * b.output_g(inputs.applied_g) for k, b in basis.items()), np.zeros(inputs.time_s.size))
    if effect.slot == "drift" and not np.allclose(out, total, rtol=0, atol=1e-15):
        _fail(cls, "contribution differs from Σ amplitude × basis")


def check_causal(cls: type[Effect], inputs: EffectInputs, k: int | None = None) -> None:
    """Changing the inputs after sample ``k`` leaves the output before ``k`` unchanged.

    Parameters
    ----------
    cls : type of Effect
        The effect class checked (at its defaults).
    inputs : EffectInputs
        Inputs to evaluate it on.
    k : int, optional
        First changed sample; default 60 % of the way through.
    """
    k = int(inputs.time_s.size * 0.6) if k is None else k
    future = inputs.replace(die_c=inputs.die_c.copy(), thermometer_c=inputs.thermometer_c.copy(),
                            applied_g=inputs.applied_g.copy(), time_since_power_on_s=inputs.time_since_power_on_s.copy())
    wiggle = 17.0 * np.sin(np.arange(inputs.time_s.size - k) / 50.0)
    future.die_c[k:] += wiggle
    future.thermometer_c[k:] += wiggle
    future.applied_g[k:] *= -1
    future.time_since_power_on_s[k:] = np.arange(inputs.time_s.size - k)
    effect = cls()
    if not np.array_equal(_outputs(effect, inputs)[:k], _outputs(effect, future)[:k]):
        _fail(cls, "not causal: changing the future changed the past")


def check_reference(cls: type[Effect], reference_c: float = 25.0, n: int = 5000) -> None:
    """An effect of temperature gives nothing at the reference temperature without history.

    Parameters
    ----------
    cls : type of Effect
        The effect class checked (at its defaults).
    reference_c : float
        Constant temperature held [°C].
    n : int
        Number of 1 s samples.
    """
    if not set(cls.reads) & {"die_c", "thermometer_c"}:
        return
    t = np.arange(n, dtype=float)
    flat = np.full(n, reference_c)
    inputs = EffectInputs(time_s=t, die_c=flat.copy(), thermometer_c=flat.copy(), applied_g=np.ones(n),
                          run_index=np.zeros(n, np.int16), time_since_power_on_s=t + 1e6)
    effect = cls()
    if effect.slot == "temperature":
        ok = np.allclose(effect.die_temperature(inputs), reference_c, rtol=0, atol=1e-12)
    else:
        ok = np.allclose(Composition([effect]).evaluate(inputs, device=True)[cls.name].output_g(inputs.applied_g),
                         0.0, rtol=0, atol=1e-15)
    if not ok:
        _fail(cls, f"non-zero at the reference {reference_c:g} °C without history")


def check_effect(cls: type[Effect]) -> None:
    """Run every conformance check on an effect class; raise :class:`EffectCheckError` on the first failure.

    For plugin authors: ``check_effect(MyEffect)`` in a test is what the built-in effects pass.

    Parameters
    ----------
    cls : type of Effect
        The effect class checked.
    """
    inputs = conformance_inputs()
    check_parameters(cls)
    check_effect_outputs(cls, inputs)
    check_causal(cls, inputs, k=12000)
    check_reference(cls)
