"""Fleets: one analysis (``twin compare`` or ``twin calibrate``) over many units' logs, locally or
on a Dask cluster, durable and resumable like ``twin doe``; the population view over the units;
and simulated fleets whose truth is kept apart.

Modules: :mod:`~twin.fleet.spec` (the fleet file and its units), :mod:`~twin.fleet.ledger`
(``units.jsonl``), :mod:`~twin.fleet.units` (one unit's analysis, run in a worker),
:mod:`~twin.fleet.runner` (executors), :mod:`~twin.fleet.result` (the typed row, population view
and command results), :mod:`~twin.fleet.population` (prevalence, parameter
distributions, robust outliers, the table), :mod:`~twin.fleet.summary` (``summary.html``) and
:mod:`~twin.fleet.simulate` (a fleet scenario → logs + ``truth.json``).
"""
