"""architecture.html (rac.targets.html): the SVG with racc's pan/zoom/search script, checked
in a real headless browser (Debian's chromium, installed by .ci/run)."""

from __future__ import annotations

import html
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from diagram_robots import tugger

from rac.cli import main
from rac.fmt import format_model
from rac.targets.html import emit_html

ROOT = Path(__file__).resolve().parents[2]
WAREHOUSE = str(ROOT / "models" / "warehouse.ram")
TEDUSAR = str(ROOT / "models" / "tedusar.ram")
HAVE_DOT = shutil.which("dot") is not None
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
AMCL = "/robot_41/localization/amcl"

SVG = (
    '<?xml version="1.0" encoding="UTF-8" standalone="no"?>\n'
    '<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN" "x">\n'
    '<svg width="10pt" height="10pt" viewBox="0.00 0.00 10.00 10.00" '
    'xmlns="http://www.w3.org/2000/svg"><g class="node"><title>a</title></g></svg>\n'
)


def test_the_page_holds_the_svg_and_fetches_nothing() -> None:
    page = emit_html(SVG, "robot <x> & y")
    assert page.startswith("<!DOCTYPE html>")
    assert "<?xml" not in page and "DTD SVG" not in page  # the <svg> element alone
    assert "<title>robot &lt;x&gt; &amp; y</title>" in page
    assert '<g class="node"><title>a</title></g></svg>' in page
    assert_fetches_nothing(page)
    assert emit_html(SVG, "t") == emit_html(SVG, "t")


def test_what_is_not_an_svg_is_refused() -> None:
    with pytest.raises(ValueError, match="no <svg>"):
        emit_html("<html></html>", "t")


def assert_fetches_nothing(page: str) -> None:
    """No script, style, image or font from elsewhere: only the SVG namespaces name a URL."""
    urls = set(re.findall(r"https?://[^\s\"'<>)]+", page))
    assert urls <= {"http://www.w3.org/2000/svg", "http://www.w3.org/1999/xlink"}, urls
    assert not re.search(r"<(script|img|link|iframe)\b[^>]*\b(src|href)=", page)
    assert "@import" not in page and "url(" not in page


def written_page(tmp_path: Path, *args: str) -> Path:
    page = tmp_path / "warehouse.html"
    assert main(["diagram", WAREHOUSE, "-o", str(page), "-q", *args]) == 0
    return page


@pytest.mark.skipif(not HAVE_DOT, reason="Graphviz dot is not installed")
def test_racc_diagram_writes_the_page_with_every_tooltip(tmp_path: Path) -> None:
    text = written_page(tmp_path).read_text("utf-8")
    assert_fetches_nothing(text)
    assert "<title>robot warehouse</title>" in text
    assert f"<title>{AMCL}</title>" in text  # Graphviz's name of the node, searched
    assert "watched: process running (NObs)" in html.unescape(text)  # the tooltip's data


@pytest.mark.skipif(not HAVE_DOT, reason="Graphviz dot is not installed")
def test_compile_writes_the_page_only_when_asked(tmp_path: Path) -> None:
    assert main(["compile", TEDUSAR, "-o", str(tmp_path / "a"), "-q"]) == 0
    assert not (tmp_path / "a" / "architecture.html").exists()
    assert main(["compile", TEDUSAR, "-o", str(tmp_path / "b"), "-q", "--html"]) == 0
    page = (tmp_path / "b" / "architecture.html").read_text("utf-8")
    assert "<title>robot tedusar</title>" in page and "<svg" in page


def browser_dom(page: Path, fragment: str, tmp_path: Path) -> str:
    """The document after the page's script ran, as headless chromium sees it, with every
    network request sent to a closed port (nothing may need the network)."""
    assert CHROMIUM is not None
    done = subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",  # root in CI containers
            "--disable-gpu",
            "--no-first-run",
            f"--user-data-dir={tmp_path / 'profile'}",
            "--proxy-server=127.0.0.1:9",
            "--window-size=1920,1080",
            "--dump-dom",
            page.as_uri() + fragment,
        ],
        capture_output=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr.decode(errors="replace")[-2000:]
    return done.stdout.decode("utf-8")


@pytest.mark.skipif(not HAVE_DOT, reason="Graphviz dot is not installed")
@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (.ci/run installs it)")
def test_a_real_browser_searches_and_shows_a_tooltip(tmp_path: Path) -> None:
    page = written_page(tmp_path)
    dom = browser_dom(page, f"#search=amcl&tip={AMCL}", tmp_path)
    ready = re.search(r'data-racc-view="ready (\d+)"', dom)
    assert ready is not None, "the page's script did not run to its end"
    assert int(ready.group(1)) > 31 + 8  # the nodes, devices, topic boxes and arrows
    # search: the node, the topic box /robot_41/amcl_pose and the arrows to and from them
    # match, the rest is dimmed
    assert re.search(r'<svg [^>]*class="searching"', dom)
    found = re.findall(
        r'<g id="(?:node|edge)\d+" class="(?:node|edge) hit" data-name="([^"]+)"', dom
    )
    hits = sorted({name for name in found if " → " not in name})
    assert hits == ["/robot_41/amcl_pose", AMCL]
    # an arrow's two edges and its label are one match, named by its ends
    arrows = {name for name in found if " → " in name}
    assert "/robot_41/localization/map_server → /robot_41/localization/amcl" in arrows
    assert f'<span id="count">{len(hits) + len(arrows)} matches</span>' in dom
    # the tooltip: the component's observers
    tip = re.search(
        r'<div id="tip" role="tooltip" data-for="([^"]+)" style="([^"]*)">(.*?)</div>', dom, re.S
    )
    assert tip is not None and tip.group(1) == AMCL and "display: block" in tip.group(2)
    shown = html.unescape(tip.group(3))
    for line in ("software node (N)", "process running (NObs)", "cpu ≤ 30 % (PObs)"):
        assert line in shown
    # no second, native tooltip on a component (a namespace box keeps its own)
    node = dom[dom.index(f'data-name="{AMCL}"') :]
    assert "xlink:title" not in node[: node.index("</g>")]


@pytest.mark.slow
@pytest.mark.skipif(not HAVE_DOT, reason="Graphviz dot is not installed")
@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (.ci/run installs it)")
def test_a_topic_on_an_arrow_is_found_and_nothing_says_so(tmp_path: Path) -> None:
    page = written_page(tmp_path)
    dom = browser_dom(page, "#search=cmd_vel_smoothed", tmp_path)
    found = re.findall(r'<g id="(?:node|edge)\d+" class="(node|edge) hit" data-name="([^"]+)"', dom)
    arrow = "/robot_41/navigation/velocity_smoother → /robot_41/navigation/collision_monitor"
    # the arrow's label (a node) and its two edges
    assert sorted(found) == [("edge", arrow), ("edge", arrow), ("node", arrow)]
    assert '<span id="count">1 match</span>' in dom
    dom = browser_dom(page, "#search=no_such_thing", tmp_path)
    assert '<span id="count">0 matches</span>' in dom
    assert not re.search(r'class="(node|edge) hit"', dom)


@pytest.mark.skipif(not HAVE_DOT, reason="Graphviz dot is not installed")
@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (.ci/run installs it)")
def test_a_hubs_copies_are_one_name_in_the_page(tmp_path: Path) -> None:
    """The tugger's task manager is drawn beside each node it talks to: a search finds its
    copies as one match, and its tooltip says so."""
    model = tmp_path / "tugger.ram"
    model.write_text(format_model(tugger()), "utf-8")
    page = tmp_path / "tugger.html"
    assert main(["diagram", str(model), "-o", str(page), "-q", "--analysis", "no"]) == 0
    dom = browser_dom(page, "#search=task_manager&tip=task_manager", tmp_path)
    found = re.findall(r'<g id="(?:node|edge)\d+" class="(node|edge) hit" data-name="([^"]+)"', dom)
    copies = [name for kind, name in found if kind == "node" and name == "task_manager"]
    assert len(copies) > 10  # a copy beside each partner, each named task_manager
    names = {name for _, name in found}
    assert f'<span id="count">{len(names)} matches</span>' in dom
    tip = re.search(
        r'<div id="tip" role="tooltip" data-for="task_manager"[^>]*>(.*?)</div>', dom, re.S
    )
    assert tip is not None and "beside the nodes it talks to (a hub)" in html.unescape(tip.group(1))
