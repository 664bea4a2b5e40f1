"""The compare report's evidence: the candidates' ΔBIC ranking and the error falling over the ledger."""

from __future__ import annotations

from dataclasses import dataclass


from twin.reporting.plots import Display


@dataclass
class CandidateRankingDisplay(Display):
    """ΔBIC of the best-ranked candidates (log scale), significant ones in red.

    Attributes
    ----------
    labels, delta_bic, significant : list
        Best first: effect (family), ΔBIC (at least 0.1) [1], significant.
    threshold : float
        ``min_delta_bic`` [1].
    """

    labels: list
    delta_bic: list
    significant: list
    threshold: float
    title = "Candidate ranking"

    @classmethod
    def from_diagnosis(cls, d, top: int = 8):
        """The ranking of a diagnosis's screened candidates; ``None`` when nothing was screened.

        Parameters
        ----------
        d : Diagnosis
            The diagnosis whose candidates are ranked.
        top : int
            Candidates shown, best first.

        Returns
        -------
        CandidateRankingDisplay or None
        """
        c = d.candidates[:top]
        if not c:
            return None
        return cls([f"{x.effect} ({x.family})" for x in c], [max(x.delta_bic, 0.1) for x in c],
                   [x.significant for x in c], d.problem.config.min_delta_bic)

    def _draw(self, ax):
        colors = ["C3" if s else "0.6" for s in self.significant]
        ax.barh(self.labels[::-1], self.delta_bic[::-1], color=colors[::-1])
        ax.set_xscale("log")
        ax.axvline(self.threshold, color="k", ls=":")
        ax.set_xlabel("ΔBIC (red: significant)")


@dataclass
class LedgerDisplay(Display):
    """The residual RMS falling as effects are added, beside the noise floor.

    Attributes
    ----------
    labels, rms_mg, noise_floor_mg : list
        Per ledger entry: the model, its residual RMS and the noise floor [mg].
    """

    labels: list
    rms_mg: list
    noise_floor_mg: list
    title = "The error falling as effects are added (ledger)"

    @classmethod
    def from_ledger(cls, ledger):
        """``None`` for fewer than two ledger entries.

        Parameters
        ----------
        ledger : list of LedgerEntry or dict
            The ledger of one data set, oldest first: a result's typed entries
            (``CompareResult.ledger``) or the lines of the ledger file.

        Returns
        -------
        LedgerDisplay or None
        """
        if len(ledger) < 2:
            return None
        ledger = [e if isinstance(e, dict) else vars(e) for e in ledger]
        models = [list(e["model"]) for e in ledger]
        labels = ["\n+ ".join(models[0]) or "offsets only"] + [_step(a, b) for a, b in zip(models, models[1:])]
        return cls(labels, [e["rms_residual_g"] * 1e3 for e in ledger], [e["noise_floor_g"] * 1e3 for e in ledger])

    def _draw(self, ax):
        x = range(len(self.labels))
        ax.plot(x, self.rms_mg, "o-", label="residual RMS")
        ax.plot(x, self.noise_floor_mg, "--", label="noise floor")
        ax.set_xticks(x, self.labels, fontsize=8)
        ax.set_xmargin(0.15)
        ax.set_ylabel("mg")
        ax.legend(fontsize=8)


def _step(before: list[str], after: list[str]) -> str:
    """A ledger step in words: the effects added (+) and removed (−) between two models."""
    changes = [f"+ {e}" for e in after if e not in before] + [f"− {e}" for e in before if e not in after]
    return "\n".join(changes) or "same model"
