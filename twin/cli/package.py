"""``twin package``: the finite-element package / die / comb model's drift prediction."""

from __future__ import annotations
