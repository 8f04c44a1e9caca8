"""MkDocs hooks of the mpmdem site (mkdocs.yml ``hooks:``).

* ``on_config``: the Gallery section of the navigation gets one page per case of
  ``cases/__init__.py``'s ``CASES``, in its order.
* ``on_files``: adds, without copying them into docs/,
  - ``bench/README.md`` (how to run the benchmark scripts) and ``bench/results/validation/h100.md``
    (the committed ``mpmdem validate`` table) as pages, and every PNG under
    ``bench/results/`` as a picture at the same path (``bench/results/...``), so pages link to the
    committed charts where they are;
  - the gallery pages ``gallery/<case>.md``, written from the case module (its header comment and
    docstring, its own flags), the table of docs/gallery/index.md (what it checks) and
    docs/gallery/gallery.json (the picture and the run that made it, ``docs/make_gallery.py``).

Nothing here imports mpmdem or Warp: the case modules are read with ``ast``.
"""

from __future__ import annotations

import ast
import json
import re
from pathlib import Path

from mkdocs.structure.files import File, InclusionLevel

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


# Full-size results of a case elsewhere in the site: (text, link from a gallery page, chart or None).
RESULTS = {
    "slope-flow": ("The full-length CPU run", None, "bench/results/cases/slope_flow/cpu.png"),
    "avalanche": ("The full-length CPU run", None, "bench/results/cases/avalanche/cpu.png"),
    "silo-filling": ("The full-length CPU run", None, "bench/results/cases/silo_filling/cpu.png"),
    "toyoura-flume": ("The full-length CPU run (load-cell force history)", None,
                      "bench/results/cases/toyoura_flume/cpu.png"),
    "silo-discharge": ("The GPU study `mpmdem study beverloo`",
                       "../studies/index.md#silo-discharge-mpm-sdem-53-fig-16",
                       "bench/results/studies/beverloo/beverloo_rate.png"),
    "sand-blocks": ("The GPU study `mpmdem study block-impact`",
                    "../studies/index.md#block-impact-mpm-sdem-6-the-experiments-geometry",
                    "bench/results/studies/block-impact/block_impact_orientation.png"),
    "column-collapse": ("The GPU study `mpmdem study column-collapse`",
                        "../studies/index.md#column-collapse-motion-integration-5",
                        "bench/results/studies/column-collapse/column_collapse_runout.png"),
    "granular-matrix": ("The fines study `bench/granular_matrix.py` (H200)",
                        "../studies/index.md#granular-matrix-mpm-sdem-7", "bench/results/granular_matrix/h200.png"),
    "axial-bar": ("Spatial convergence per shape function, `bench/convergence.py`",
                  "../benchmarks.md", "bench/results/convergence/cpu.png"),
    "rotating-disk": ("Every transfer scheme and update order, `bench/motion_integration.py`",
                      "../benchmarks.md", "bench/results/motion_integration/h100_pareto.png"),
    "bouncing-disk": ("Every transfer scheme and update order, `bench/motion_integration.py`",
                      "../benchmarks.md", "bench/results/motion_integration/h100_pareto.png"),
    "disk-drop": ("The coupled time step's stability map, `bench/coupling_stability.py`",
                  "../benchmarks.md", "bench/results/coupling_stability/cpu.png"),
}


def case_names() -> dict[str, str]:
    """CASES of cases/__init__.py (CLI name → module name), read without importing it."""
    tree = ast.parse((ROOT / "cases" / "__init__.py").read_text(encoding="utf-8"))
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
        if any(isinstance(t, ast.Name) and t.id == "CASES" for t in targets):
            return ast.literal_eval(node.value)
    raise RuntimeError("cases/__init__.py has no CASES")


def on_config(config, **kwargs):
    gallery = [{name: f"gallery/{name}.md"} for name in case_names()]
    for i, entry in enumerate(config.nav):
        if isinstance(entry, dict) and "Gallery" in entry:
            config.nav[i] = {"Gallery": ["gallery/index.md", *gallery]}
    return config


def _header(source: str) -> str:
    """The leading comment block of a module as Markdown (bullets and indented formulas kept)."""
    lines = []
    for line in source.splitlines():
        if not line.startswith("#"):
            break
        lines.append(line[2:] if line.startswith("# ") else line[1:])
    text = "\n".join(lines)
    # A bullet list needs a blank line before it; "* " bullets continue on indented lines.
    text = re.sub(r"(?m)^(?!\* )(.+)\n\* ", r"\1\n\n* ", text)
    return text


def _flags(tree: ast.Module) -> list[tuple[str, str]]:
    """(flag, help) of every parser.add_argument call in the module's add_arguments()."""
    out = []
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name == "add_arguments":
            for call in ast.walk(node):
                if (isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute)
                        and call.func.attr == "add_argument" and call.args
                        and isinstance(call.args[0], ast.Constant)):
                    help_text = next((kw.value for kw in call.keywords if kw.arg == "help"), None)
                    text = help_text.value if isinstance(help_text, ast.Constant) else ""
                    out.append((str(call.args[0].value), str(text)))
    return out


def _checks() -> dict[str, str]:
    """case → 'what it checks', from the table of docs/gallery/index.md."""
    rows = {}
    for line in (DOCS / "gallery" / "index.md").read_text(encoding="utf-8").splitlines():
        m = re.match(r"\|\s*\[`([a-z0-9-]+)`\]\([^)]*\)\s*\|(.*)\|\s*$", line)
        if m:
            rows[m.group(1)] = m.group(2).strip()
    return rows


def case_page(name: str, module: str, checks: dict[str, str], gallery: dict) -> str:
    source = (ROOT / "cases" / f"{module}.py").read_text(encoding="utf-8")
    tree = ast.parse(source)
    doc = (ast.get_docstring(tree) or "").strip()
    parts = [f"# `{name}`\n", f"*{doc}*\n" if doc else ""]
    record = gallery.get(name, {})
    if record.get("picture"):
        parts.append(f"![{name}]({record['picture']})\n")
        parts.append(f"<small>`{record['command']}`, drawn with `{record['how']}` "
                     f"(`docs/make_gallery.py`; the run took {record['wall_seconds']} s on 2 CPU cores).</small>\n")
    elif record.get("fallback"):
        parts.append(f"![{name}](../{record['fallback']})\n")
        parts.append(f"<small>A committed chart, `{record['fallback']}`: the quick CPU run "
                     f"({record.get('status', 'not run')}) gave no gallery picture.</small>\n")
    parts.append("## What it checks\n")
    parts.append((checks.get(name, "") or "(see the case module)") + "\n")
    if name in RESULTS:
        text, link, chart = RESULTS[name]
        parts.append("## Full-size results\n")
        label = "Studies and validation" if link and "studies" in link else "Benchmarks"
        parts.append(f"{text}: see [{label}]({link}), and `{chart}`:" if link else f"{text}, `{chart}`:")
        if chart and (not record.get("fallback") or record.get("picture")):
            parts.append(f"\n![{name}: full-size results](../{chart})\n")
    parts.append("## What it models\n")
    parts.append(f"From the header of `cases/{module}.py`:\n")
    parts.append(_header(source) + "\n")
    parts.append("## Run it\n")
    parts.append(f"```bash\nmpmdem run {name}                 # or: python cases/{module}.py\n"
                 f"mpmdem run {name} --quick --device cpu\n```\n")
    flags = _flags(tree)
    if flags:
        parts.append("Its own flags (besides the [common flags](../guide/cli.md)):\n")
        parts.append("| flag | meaning |\n| --- | --- |")
        parts.extend(f"| `{flag}` | {text.replace('|', '&#124;')} |" for flag, text in flags)
        parts.append("")
    return "\n".join(parts) + "\n"


def on_files(files, config, **kwargs):
    pages = [ROOT / "bench" / "README.md", ROOT / "bench" / "results" / "validation" / "h100.md"]
    for path in [*pages, *sorted((ROOT / "bench" / "results").rglob("*.png"))]:
        uri = path.relative_to(ROOT).as_posix()
        files.append(File.generated(config, uri, abs_src_path=str(path), inclusion=InclusionLevel.INCLUDED))
    index = DOCS / "gallery" / "gallery.json"
    gallery = json.loads(index.read_text(encoding="utf-8")) if index.is_file() else {}
    checks = _checks()
    for name, module in case_names().items():
        content = case_page(name, module, checks, gallery)
        files.append(File.generated(config, f"gallery/{name}.md", content=content,
                                    inclusion=InclusionLevel.INCLUDED))
    return files
