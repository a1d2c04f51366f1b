#!/usr/bin/env python3
"""LICENSE, CITATION.cff and packaging/debian/copyright agree with each other
and with the project: the licence named the same everywhere, CITATION.cff
well-formed (CFF 1.2.0's required keys) at the project's version, every
licence a Files stanza names given in full, and the embedded uPlot's version
the one monitor/web/package.json fetches.

    check_citation.py REPO
"""
import json
import re
import sys

import yaml

SPDX_OF_LICENSE_TITLE = {"BSD 3-Clause License": "BSD-3-Clause"}


def fail(message):
    print(f"check_citation: {message}", file=sys.stderr)
    sys.exit(1)


def main():
    repo = sys.argv[1]
    with open(f"{repo}/LICENSE", encoding="utf-8") as f:
        title = f.readline().strip()
    if title not in SPDX_OF_LICENSE_TITLE:
        fail(f"LICENSE: first line {title!r} is not a licence this check knows")
    spdx = SPDX_OF_LICENSE_TITLE[title]

    with open(f"{repo}/CMakeLists.txt", encoding="utf-8") as f:
        version = re.search(r"project\(rocklab VERSION ([0-9.]+)", f.read()).group(1)
    with open(f"{repo}/CITATION.cff", encoding="utf-8") as f:
        cff = yaml.safe_load(f)
    for key in ("cff-version", "message", "title", "authors"):
        if key not in cff:
            fail(f"CITATION.cff: no {key!r}")
    if cff["cff-version"] != "1.2.0":
        fail(f"CITATION.cff: cff-version {cff['cff-version']!r}, expected '1.2.0'")
    if str(cff.get("version")) != version:
        fail(f"CITATION.cff: version {cff.get('version')!r}, CMakeLists.txt says {version}")
    if cff.get("license") != spdx:
        fail(f"CITATION.cff: license {cff.get('license')!r}, LICENSE is {spdx}")
    paper = cff.get("preferred-citation", {})
    if paper.get("type") != "conference-paper" or len(paper.get("authors", [])) != 3:
        fail("CITATION.cff: preferred-citation is not the paper (a conference paper by three authors)")

    with open(f"{repo}/packaging/debian/copyright", encoding="utf-8") as f:
        paragraphs = [p for p in f.read().split("\n\n") if p.strip()]
    stanzas, texts = [], set()
    for p in paragraphs:
        fields = dict(re.findall(r"^([A-Za-z-]+):[ \t]*(.*)$", p, re.M))
        if "Files" in fields:
            stanzas.append(fields)
        elif "License" in fields and "Format" not in fields:
            if len(p.strip().splitlines()) < 5:
                fail(f"copyright: the text of licence {fields['License']!r} is missing")
            texts.add(fields["License"])
    if not stanzas or stanzas[0]["Files"] != "*" or stanzas[0]["License"] != spdx:
        fail(f"copyright: the first stanza must be 'Files: *' under {spdx}")
    for s in stanzas:
        if s["License"] not in texts:
            fail(f"copyright: Files {s['Files']!r} names licence {s['License']!r}, whose text is not given")
    with open(f"{repo}/monitor/web/package.json", encoding="utf-8") as f:
        uplot = json.load(f)["dependencies"]["uplot"]
    if not any("uplot" in s["Files"] and f"uPlot {uplot}" in p for s in stanzas for p in paragraphs):
        fail(f"copyright: no stanza for the embedded uPlot {uplot} (monitor/web/package.json)")
    print(f"check_citation: {spdx}, version {version}, {len(stanzas)} Files stanzas")


if __name__ == "__main__":
    main()
