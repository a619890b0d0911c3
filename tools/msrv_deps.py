#!/usr/bin/env python3
"""Fails when a package of the locked dependency graph declares a
rust-version newer than the workspace's (CI's MSRV check, with clippy's
`incompatible_msrv` for our own code). Reads `cargo metadata` on stdin:

    cargo metadata --format-version 1 --locked --offline | python3 tools/msrv_deps.py 1.90
"""
import json
import sys


def version(text):
    return tuple(int(part) for part in text.split(".")[:2])


msrv = version(sys.argv[1])
newer = [
    f"{p['name']} {p['version']} declares rust-version {p['rust_version']}"
    for p in json.load(sys.stdin)["packages"]
    if p.get("rust_version") and version(p["rust_version"]) > msrv
]
if newer:
    print(f"newer than the MSRV {sys.argv[1]}:\n  " + "\n  ".join(newer))
    sys.exit(1)
print(f"every locked package builds on Rust {sys.argv[1]} or declares no MSRV")
