"""``twin fleet``: compare (and calibrate) over many units' logs, locally or on Dask."""

from __future__ import annotations
