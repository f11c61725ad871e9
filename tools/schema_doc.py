#!/usr/bin/env python3
"""Render the scenario, platform and workload JSON Schemas as a Markdown reference.

The schemas under scenarios/schema/ are the source of truth for every key, type, default and
allowed value; docs/scenario-reference.md is generated from them so that it cannot drift:
    python3 tools/schema_doc.py > docs/scenario-reference.md
A test (tests/CMakeLists.txt: docs/scenario-reference) fails when the file is out of date.
"""
import json
import sys
from pathlib import Path

SCHEMA_DIR = Path(__file__).resolve().parent.parent / "scenarios" / "schema"
DOCS = {name: json.loads((SCHEMA_DIR / name).read_text())
        for name in ("scenario.schema.json", "platform.schema.json", "workload.schema.json",
                     "guard.schema.json")}


def resolve(node, doc):
    """Follows $ref (local '#/definitions/x' or 'file.json#/...'); returns (node, doc name)."""
    while isinstance(node, dict) and "$ref" in node:
        ref = node["$ref"]
        file, _, pointer = ref.partition("#")
        doc = file or doc
        node = DOCS[doc]
        for part in filter(None, pointer.split("/")):
            node = node[part]
    return node, doc


def type_text(node):
    if "enum" in node:
        return " \\| ".join(f"`{json.dumps(v)}`" for v in node["enum"])
    t = node.get("type", "")
    t = " or ".join(t) if isinstance(t, list) else t
    bounds = []
    if "minimum" in node:
        bounds.append(f">= {node['minimum']}")
    if "exclusiveMinimum" in node:
        bounds.append(f"> {node['exclusiveMinimum']}")
    if "maximum" in node:
        bounds.append(f"<= {node['maximum']}")
    if "exclusiveMaximum" in node:
        bounds.append(f"< {node['exclusiveMaximum']}")
    if "minItems" in node:
        bounds.append(f"at least {node['minItems']} item(s)")
    return t + (f" ({', '.join(bounds)})" if bounds else "")


def rows(node, doc, prefix, out, required=()):
    node, doc = resolve(node, doc)
    for key, sub in node.get("properties", {}).items():
        if key == "$schema":
            continue
        sub_r, sub_doc = resolve(sub, doc)
        path = f"{prefix}{key}"
        item = sub_r.get("items")
        if isinstance(item, dict):
            item_r, _ = resolve(item, sub_doc)
        default = json.dumps(sub_r["default"]) if "default" in sub_r else (
            "required" if key in required else "")
        desc = sub_r.get("description", "")
        if "items" in sub_r and isinstance(item, dict) and "properties" in item_r:
            out.append((path, "list of objects", default, desc))
            rows(item, sub_doc, f"{path}[].", out, item_r.get("required", ()))
        elif "properties" in sub_r:
            out.append((path, "object", default, desc))
            rows(sub_r, sub_doc, f"{path}.", out, sub_r.get("required", ()))
        else:
            out.append((path, type_text(sub_r), default, desc))


def table(title, schema_name, intro):
    doc = DOCS[schema_name]
    out = []
    rows(doc, schema_name, "", out, doc.get("required", ()))
    lines = [f"## {title}", "", intro, "", "| key | type / allowed | default | meaning |",
             "|---|---|---|---|"]
    for path, t, default, desc in out:
        default = f"`{default}`" if default not in ("", "required") else default
        lines.append(f"| `{path}` | {t} | {default} | {desc} |")
    return "\n".join(lines) + "\n"


def main():
    parts = [
        "# Scenario, platform, workload and guard files\n",
        "Generated from `scenarios/schema/*.schema.json` by `tools/schema_doc.py`; do not edit "
        "by hand. Unknown keys are errors; absent keys take the default shown. Add "
        "`\"$schema\": \"../schema/scenario.schema.json\"` to a scenario so that an editor "
        "completes and checks it.\n",
        table("Scenario (`scenarios/*.json`)", "scenario.schema.json",
              DOCS["scenario.schema.json"]["description"]),
        "A workload (`nodes.rt[].workload`, `nodes.nrt[].workload`) is a name under "
        "`scenarios/workloads/`, a path to a workload file (relative to the scenario), or an "
        "inline object: a workload document as below, or `{\"command\": [...]}` for an external "
        "program (hw backend only).\n",
        table("Workload (`scenarios/workloads/*.json`)", "workload.schema.json",
              DOCS["workload.schema.json"]["description"]),
        table("Platform (`scenarios/platforms/*.json`)", "platform.schema.json",
              DOCS["platform.schema.json"]["description"]),
        table("Guard configuration (`rosguard guard CONFIG.json`; example: "
              "`docs/guard/example.json`)", "guard.schema.json",
              DOCS["guard.schema.json"]["description"]),
    ]
    sys.stdout.write("\n".join(parts))


if __name__ == "__main__":
    main()
