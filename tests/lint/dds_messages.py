#!/usr/bin/env python3
"""The ROS 2 interface files (hw/topic/dds/rosguard_msgs/msg/*.msg) and their DDS form
(hw/topic/dds/idl/*.idl, compiled by idlc) must describe the same fields in the same order with
the same types: a ROS 2 node decodes the wire with the .msg, rosguard encodes it with the .idl.

    dds_messages.py SOURCE_DIR     exit 0 when they agree, 1 with the differences listed
"""
import re
import sys
from pathlib import Path

# ROS 2 primitive -> IDL type (rosidl's mapping).
ROS_TO_IDL = {"bool": "boolean", "byte": "octet", "char": "uint8", "float32": "float",
              "float64": "double", "int8": "int8", "uint8": "uint8", "int16": "int16",
              "uint16": "uint16", "int32": "int32", "uint32": "uint32", "int64": "int64",
              "uint64": "uint64"}


def msg_fields(path):
    fields = []
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        typ, name = line.split()[:2]
        if "=" in name:
            continue  # a constant: not on the wire
        m = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", typ)
        if not m or m.group(1) not in ROS_TO_IDL:
            raise SystemExit(f"{path}: unsupported field type {typ}")
        fields.append((ROS_TO_IDL[m.group(1)], name, m.group(2)))
    return fields


def idl_fields(path, struct):
    text = re.sub(r"//.*", "", path.read_text())
    body = re.search(r"struct\s+" + struct + r"\s*\{(.*?)\};", text, re.S)
    if not body:
        raise SystemExit(f"{path}: no struct {struct}")
    fields = []
    for decl in filter(None, (d.strip() for d in body.group(1).split(";"))):
        m = re.fullmatch(r"(\w+)\s+(\w+)(?:\[(\d+)\])?", decl)
        if not m:
            raise SystemExit(f"{path}: cannot read field '{decl}'")
        fields.append((m.group(1), m.group(2), m.group(3)))
    return fields


def main(src):
    root = Path(src) / "hw" / "topic" / "dds"
    fails = []
    msgs = sorted((root / "rosguard_msgs" / "msg").glob("*.msg"))
    if not msgs:
        fails.append("no .msg files found")
    for msg in msgs:
        idl = root / "idl" / (msg.stem + ".idl")
        if not idl.exists():
            fails.append(f"{msg.name}: no {idl.name}")
            continue
        text = idl.read_text()
        if not re.search(r"module\s+rosguard_msgs\s*\{\s*module\s+msg\s*\{\s*module\s+dds_", text):
            fails.append(f"{idl.name}: not in module rosguard_msgs::msg::dds_ (the ROS 2 type name)")
        a, b = msg_fields(msg), idl_fields(idl, msg.stem + "_")
        if a != b:
            fails.append(f"{msg.name} {a} != {idl.name} {b}")
    for f in fails:
        print("FAIL:", f)
    print(f"{len(msgs)} message(s) checked")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
