"""Look-alike mechanisms: the physical mechanisms that share one residual signature.

A diagnosis names a *signature* (the residual follows −dT/dt; it relaxes after each temperature
change); several mechanisms, some outside the effect library, make that signature. For each
family (and for a few effects, more precisely) the catalogue lists each mechanism with a
one-line physical reason, whether the library holds it (the effect's name, or ``None``) and the
test that tells it from the others. References: Nadimi & Bhatia, *IEEE Sensors J.* 2019
(package stress), Krondorfer et al., *Microelectron. Reliab.* 2004 (mould-compound moisture
swelling), Walwadkar & Cho, *IEEE Trans. Compon. Packag. Technol.* 2006 (die-attach creep),
Lamy et al. (thermal gradients in MEMS), IEEE Std 1293 (tempco and warm-up terms).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass


#: slow noise that a drift of hours resembles (screening retests every candidate with it allowed)
RANDOM_WALK = "bias random walk of the sensor"
_WALK_TEST = "repeat the test: a physical drift repeats, a random walk does not"


@dataclass(frozen=True)
class Mechanism:
    """One physical mechanism that makes a residual signature.

    Attributes
    ----------
    name : str
        The mechanism, in words.
    effect : str or None
        The library effect that models it, or ``None`` (outside the library).
    reason : str
        One line: why it makes this signature.
    test : str
        What separates it from the others.
    """

    name: str
    effect: str | None  # the library effect that models it, or None (outside the library)
    reason: str  # one line: why it makes this signature
    test: str  # what separates it from the others

    @property
    def in_library(self) -> bool:
        """Whether a library effect models the mechanism [bool]."""
        return self.effect is not None


_LAG = (
    Mechanism("die lags the thermometer", "thermal_lag",
              "the die's heat capacity behind the board and package delays its temperature",
              "a second ramp rate: the lag error scales with rate; a probe glued on the package moves it"),
    Mechanism("thermal gradient across the die", "thermal_gradient",
              "a ramp sets a temperature difference across the proof mass and anchors, which bends the structure",
              "a different mounting (a thermal pad or a metal fixture): the gradient changes, a pure lag does not"),
    Mechanism("air-flow or convection coupling", None,
              "the chamber fan's air moves with the ramp and loads the package differently on heating and cooling",
              "repeat with the fan at another speed or the device in a closed box"),
)
_RELAX = (
    Mechanism("viscoelastic creep of mould or die attach", "stress_relaxation",
              "polymer stress relaxes for hours after each temperature change (Maxwell/Prony creep)",
              "a bake (125 °C, 24 h) leaves creep unchanged; hold longer dwells: creep follows a Prony series"),
    Mechanism("moisture uptake of the mould compound", None,
              "the epoxy swells as it absorbs water after a temperature change, straining the die",
              "log humidity or run with a dry-nitrogen purge; a bake removes it for days"),
    Mechanism("play-type hysteresis (friction, stiction of the package)", "thermal_hysteresis",
              "stress stored by a slip at the interfaces remembers the path, independent of rate",
              "a second ramp rate and reversals of different size: play widths stay fixed, creep decays"),
    Mechanism(RANDOM_WALK, None, "slow noise, not physics: a walk that drifts after a step looks like a relaxation",
              _WALK_TEST),
)

#: family → mechanisms that share its signature
CATALOGUE: dict[str, tuple[Mechanism, ...]] = {
    "thermal_lag": _LAG,
    "hysteresis": _RELAX,
    "bias_tc": (
        Mechanism("MEMS bias tempco", "static_bias_tc", "the sensing element's offset moves with temperature",
                  "another package or board with the same die"),
        Mechanism("package stress (CTE mismatch)", "package_stress",
                  "the mould, die and board expand differently and strain the die", "a different mounting or a "
                  "softer die attach"),
        Mechanism("ASIC offset tempco", None, "the readout's offset drifts with its own temperature",
                  "the self-test or an electrical-only input"),
    ),
    "scale_factor": (
        Mechanism("comb-gap expansion", "comb_expansion", "thermal expansion changes the sensing gaps",
                      "a tumble (±1 g) at several temperatures"),
        Mechanism("spring stiffness tempco", "stiffness_tc", "Young's modulus of silicon falls with temperature",
                  "a tumble at several temperatures"),
        Mechanism("reference-voltage tempco of the ASIC", None, "the readout's gain follows its reference",
                  "a tumble and the part's self-test at two temperatures"),
    ),
    "aging": (
        Mechanism("long-term settling", "aging_drift", "stress and charge settle over days",
                  "repeat identical cycles days apart"),
        Mechanism("moisture desorption or uptake", None, "the mould's water content drifts with the room's humidity",
                  "log humidity or a dry purge; a bake resets it"),
        Mechanism(RANDOM_WALK, None, "slow noise, not physics: it does not repeat", _WALK_TEST),
    ),
    "warmup": (
        Mechanism("self-heating after power-on", "warmup", "the ASIC heats the die for minutes after power-on",
                  "power-cycle at several chamber temperatures"),
        Mechanism("charge settling of the readout", None, "the front end's bias network charges after power-on",
                  "power-cycle with the chamber off: a charge transient does not depend on temperature"),
    ),
    "discovered": (
        Mechanism("outside the library", None, "a term the dictionary search found; no physical model attached",
                  "a test that varies the term's input alone (rate, threshold, oscillation)"),
    ),
}

#: the signature of a discovered feature kind → family whose look-alikes it shares
FEATURE_FAMILY = {"rate": "thermal_lag", "lag": "thermal_lag", "abs_rate": "thermal_lag", "rate2": "thermal_lag",
                  "temp_rate": "thermal_lag", "since_change": "hysteresis", "play": "hysteresis",
                  "power_on": "warmup", "trend": "aging", "power": "bias_tc", "step": "bias_tc",
                  "oscillation": "thermal_lag", "hold_sine": "thermal_lag"}


def lookalikes(family: str, effect: str | None = None) -> list[Mechanism]:
    """Mechanisms that share ``family``'s signature, the named ``effect``'s first.

    Parameters
    ----------
    family : str
        The effect family (a key of :data:`CATALOGUE`).
    effect : str, optional
        The named effect.

    Returns
    -------
    list of Mechanism
        The family's mechanisms, ``effect``'s first; empty for an unknown family.
    """
    mechs = list(CATALOGUE.get(family, ()))
    return sorted(mechs, key=lambda m: m.effect != effect)


def attribution(family: str, effect: str | None) -> str:
    """``"mechanism"`` when no mechanism outside the library shares the signature, else ``"signature"``.

    Parameters
    ----------
    family : str
        The effect family.
    effect : str or None
        The named effect.

    Returns
    -------
    str
        ``"mechanism"`` or ``"signature"``.
    """
    return "signature" if any(not m.in_library for m in lookalikes(family, effect)) else "mechanism"


def lookalikes_json(family: str, effect: str | None) -> list[dict]:
    """The catalogue entries as plain data, with ``in_library``.

    Parameters
    ----------
    family : str
        The effect family.
    effect : str or None
        The named effect, listed first.

    Returns
    -------
    list of dict
        One dict of :class:`Mechanism` fields and ``in_library`` per mechanism.
    """
    return [{**asdict(m), "in_library": m.in_library} for m in lookalikes(family, effect)]


def lookalikes_sentence(family: str, effect: str | None) -> str:
    """One sentence naming the other mechanisms and the tests that separate them ('' if none).

    Parameters
    ----------
    family : str
        The effect family.
    effect : str or None
        The named effect (left out of the sentence).

    Returns
    -------
    str
        The sentence, or ``""`` when no other mechanism shares the signature.
    """
    others = [m for m in lookalikes(family, effect) if m.effect != effect]
    if not others:
        return ""
    items = "; ".join(f"{m.name}{'' if m.in_library else ' (outside the library)'} — {m.reason}; to tell: {m.test}"
                      for m in others)
    return f"The same signature can also come from: {items}."
