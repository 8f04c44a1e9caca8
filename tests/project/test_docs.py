"""The documentation site builds: ``mkdocs build --strict`` (no broken link, anchor or reference)."""

import json
import os
import re
import shutil
import subprocess
import sys

import pytest
from helpers import ROOT

pytest.importorskip("mkdocs", reason="the docs extra is not installed (pip install '.[docs]')")
pytest.importorskip("material", reason="mkdocs-material is not installed (pip install '.[docs]')")
pytest.importorskip("mkdocstrings_handlers.python", reason="mkdocstrings[python] is not installed")


def test_docs_build_strict(tmp_path):
    site = tmp_path / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
                           str(ROOT / "mkdocs.yml"), "--site-dir", str(site)],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
    assert (site / "index.html").is_file()
    # every case of the registry has a gallery page with a picture (its own run or a committed chart)
    from mpmdem.cases import CASES

    gallery = json.loads((ROOT / "docs" / "gallery" / "gallery.json").read_text())
    for name in CASES:
        page = site / "gallery" / name / "index.html"
        assert page.is_file(), name
        assert "<img" in page.read_text(encoding="utf-8"), f"{name}: no picture"
        record = gallery[name]
        assert record["picture"] or record["fallback"], name
    # the API reference was rendered from the docstrings
    api = (site / "api" / "simulation" / "index.html").read_text(encoding="utf-8")
    assert "SolverConfig" in api and "Simulation" in api and "add_rigid_body" in api
    shutil.rmtree(site)


def test_readme_links_resolve():
    """Every relative link and picture of README.md points at a file of the repository."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"\]\(([^)\s]+)\)", text)
    assert links
    for link in links:
        if "://" in link or link.startswith("#"):
            continue
        assert (ROOT / link.split("#")[0]).exists(), link
