"""The one page builder every HTML report uses: escaped text, self-contained, nothing off the page."""

from twin.reporting.page import Page


def test_page_escapes_text_and_is_self_contained(tmp_path):
    page = Page("a <b> title", ["first sentence <script>", ""])
    page.heading("tables").table([["x<y", "1.5", "-2 %"]], ["name", "value [mg]", "share"])
    page.code("bias = +0.31 mg/(°C/min) · rate " * 20).figure(None, "absent").figure("QUJD", "a plot")
    html = page.write(tmp_path / "r" / "report.html").read_text()
    assert html.startswith("<!doctype html>") and "<script>" not in html and "&lt;script&gt;" in html
    assert "x&lt;y" in html and "<td class='num'>1.5</td>" in html and "<td class='num'>-2 %</td>" in html
    assert "http" not in html.split("<body>")[1]  # no external resource: the page opens offline
    # wide content wraps or scrolls inside its box rather than running off the page
    assert "white-space:pre-wrap" in html and "overflow-x:auto" in html and "max-width:100%" in html
    assert html.count("<figure>") == 1 and "alt='a plot'" in html
    assert html.index("first sentence") < html.index("<h2>tables</h2>")  # the summary comes first
