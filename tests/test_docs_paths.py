"""No path outside the repository in code or docs, and a README that stays a landing page.

A clone has only what is in the repository: code and docs cite ``docs/physics.md §X.Y`` (or
another docs page), never notes kept beside the project or a machine's absolute path. The real
logs' location is data, not a citation: it lives in ``tests/conftest.py`` (``SHARED``), which is
not scanned here. Files the repository ignores (``.gitignore``: built docs, generated pages, caches)
are not scanned either.
"""

import fnmatch
import re

from conftest import ROOT

# benchmarks/results: the JSON the docs' performance page is rendered from
SCANNED_DIRS = ("twin", "sim", "fitting", "scenarios", "docs", "benchmarks/results")
SCANNED_FILES = ("README.md",)
TEXT_SUFFIXES = {".py", ".md", ".rst", ".txt", ".yaml", ".yml", ".json", ".toml", ".cfg", ".ini", ".html",
                 ".css", ".js", ".csv", ".tsv"}
FORBIDDEN = re.compile(r"\.\./shared|physics-notes|diagnosis-methods|package-stress|physics_reference\.json"
                       r"|(?<![\w.])/(work|tmp|home)/")
README_MAX_LINES = 200


def _ignored_patterns() -> list[str]:
    gitignore = ROOT / ".gitignore"
    if not gitignore.exists():
        return []
    lines = (line.strip() for line in gitignore.read_text(encoding="utf-8").splitlines())
    return [line for line in lines if line and not line.startswith(("#", "!"))]


def _is_ignored(rel: str, patterns: list[str]) -> bool:
    parts = rel.split("/")
    for pattern in patterns:
        anchored = "/" in pattern.rstrip("/")
        pat = pattern.strip("/")
        if pattern.endswith("/"):  # a directory: any prefix of the path (or, unanchored, any component)
            if anchored:
                candidates = ["/".join(parts[:i]) for i in range(1, len(parts))]
            else:
                candidates = parts[:-1]
            if any(fnmatch.fnmatchcase(c, pat) for c in candidates):
                return True
        elif anchored:
            if fnmatch.fnmatchcase(rel, pat):
                return True
        elif any(fnmatch.fnmatchcase(c, pat) for c in parts):
            return True
    return False


def scanned_files() -> list:
    """The repository's text files under the scanned folders, and the README (ignored files left out)."""
    patterns = _ignored_patterns() + ["__pycache__/", "_build/"]
    found = [ROOT / name for name in SCANNED_FILES]
    for folder in SCANNED_DIRS:
        found += [p for p in (ROOT / folder).rglob("*") if p.is_file() and p.suffix.lower() in TEXT_SUFFIXES]
    return sorted(p for p in found if p.exists() and not _is_ignored(p.relative_to(ROOT).as_posix(), patterns))


def test_no_path_outside_the_repository():
    files = scanned_files()
    assert any(p.name == "physics.md" for p in files), "docs/physics.md is not scanned"
    hits = []
    for path in files:
        for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            match = FORBIDDEN.search(line)
            if match:
                hits.append(f"{path.relative_to(ROOT)}:{number}: {match.group(0)!r} in {line.strip()[:100]}")
    assert not hits, ("cite docs/physics.md (or another docs page) instead of notes outside the repository, "
                      "and no absolute path:\n" + "\n".join(hits))


def test_readme_is_a_landing_page():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines; move detail into docs/"


def test_the_checks_see_what_they_should():
    assert FORBIDDEN.search("see ../shared/reference/x.md") and FORBIDDEN.search("physics-notes §2.6")
    assert FORBIDDEN.search("(physics_reference.json FR4_xy)") and FORBIDDEN.search("open('/work/main/x')")
    assert not FORBIDDEN.search("docs/physics.md §2.6") and not FORBIDDEN.search("/shared/out/line_a")
    assert not FORBIDDEN.search("path/to/work/x")
    patterns = ["docs/_build/", "__pycache__/", "*.egg-info/", "docs/performance.md", "out/"]
    assert _is_ignored("docs/_build/html/index.html", patterns)
    assert _is_ignored("twin/effects/__pycache__/x.py", patterns)
    assert _is_ignored("docs/performance.md", patterns)
    assert not _is_ignored("docs/physics.md", patterns) and not _is_ignored("twin/out.py", patterns)


def test_performance_page_is_rendered_from_the_json(tmp_path):
    """Every figure on the performance page comes from a benchmark JSON, with the machine named."""
    import json
    import sys

    sys.path.insert(0, str(ROOT / "docs"))
    from performance_page import render

    (tmp_path / "bench_x.json").write_text(json.dumps({
        "benchmark": "x vs peer", "wall_s": 12.3,
        "cases": {"a": {"rate": 0.5, "ci95": [0.4, 0.6]}, "b": {"rate": 0.75, "ok": True}},
        "ratio_to_peer": 1.234567, "rows": [{"seed": 0}],
        "machine": {"cpu_model": "AMD EPYC", "logical_cpus": 2, "libraries": {"numpy": "2.0"}}}))
    page = render(tmp_path)
    assert "## x vs peer" in page and "**AMD EPYC**, 2 logical CPUs" in page and "numpy 2.0" in page
    assert "| cases | rate | ci95 | ok |" in page
    assert "| a | 0.5 | 0.4, 0.6 |  |" in page and "| b | 0.75 |  | yes |" in page
    assert "| ratio_to_peer | 1.235 |" in page and "seed" not in page  # per-row detail stays in the file
    assert "took 12 s" in page


def test_the_targets_table_reads_each_figure_from_its_json(tmp_path):
    """The real-log-scale targets: the value of the JSON, met or not by the target's own test."""
    import json
    import sys

    sys.path.insert(0, str(ROOT / "docs"))
    from performance_page import targets

    assert targets(tmp_path) == []  # no JSON, no table
    (tmp_path / "bench_long.json").write_text(json.dumps(
        {"compare_vs_pandas_read_24h": {"ratio_compare_over_pandas_read": 4.2}, "compare": {"24h": {"peak_rss_mb": 800}}}))
    (tmp_path / "bench_calibrate_scale.json").write_text(json.dumps({"logs": {
        "0.54M": {"twin_calibrate": {"us_per_row": 9.0}}, "2.16M": {"twin_calibrate": {"us_per_row": 8.5}}}}))
    page = "\n".join(targets(tmp_path))
    assert "| 24-h 100-Hz log: `twin compare` / pandas read | 4.20× | ≤ 4× | **not met** |" in page
    assert "peak memory | 800 MB | ≤ 1000 MB | met |" in page
    assert "µs per row at 2.16 M rows | 8.50 | ≤ the 0.54 M figure | met |" in page
    assert "PSO-GA" not in page  # a benchmark not run is not shown
