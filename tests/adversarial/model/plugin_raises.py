"""A plugin that raises while it is imported."""

raise RuntimeError("boom while importing")
