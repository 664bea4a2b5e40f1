"""Shared by the benchmark scripts: write the JSON result and echo it."""

import json
from pathlib import Path


def write_json(path: str | Path, result: dict) -> None:
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
