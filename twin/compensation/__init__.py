"""Compensation: the compensator registry (:mod:`~twin.compensation.registry`), the paper's
compensation benchmark on data whose truth is known, its splits and its report."""
