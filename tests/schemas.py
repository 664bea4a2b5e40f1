"""Check a command's ``--json`` output against the schema ``twin schema`` ships for it."""

import jsonschema

from twin.workflows.schemas import result_schema


def check_schema(doc: dict, result: str) -> None:
    """Raise when ``doc`` does not match the schema of ``result`` (e.g. ``"compare"``)."""
    schema = result_schema(result)
    jsonschema.Draft202012Validator.check_schema(schema)
    errors = sorted(jsonschema.Draft202012Validator(schema).iter_errors(doc), key=lambda e: list(e.path))
    assert not errors, "; ".join(f"{'/'.join(map(str, e.path))}: {e.message[:200]}" for e in errors[:5])
