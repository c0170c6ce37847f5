#!/usr/bin/python3
"""Summarises `leap bench` runs against the skipping targets: per configuration (volume, size,
step, transfer function) the frame ms of every mode (median over views), sparseleap's speedup
over naive, the ideal speedup (naive samples / sparseleap samples), the share of list building
in sparseleap's frame, sparseleap against octree, and frame / floor; with --before, the same
figures of an earlier build side by side. Prints Markdown.

usage: scripts/compare-bench.py LABEL=DIR [LABEL=DIR ...] [--before LABEL=DIR ...]

Each DIR holds a bench's results.csv and report.md; LABEL names its transfer function.
"""
import csv
import re
import statistics
import sys


def load(directory):
    rows = list(csv.DictReader(open(f"{directory}/results.csv")))
    groups = {}
    for r in rows:
        key = (r["volume"], int(r["width"]), int(r["height"]), float(r["step"]))
        groups.setdefault(key, {}).setdefault(r["mode"], []).append(r)
    out = {}
    for key, modes in groups.items():
        out[key] = {}
        for mode, rs in modes.items():
            med = lambda c: statistics.median(float(r[c]) for r in rs)
            mean = lambda c: statistics.fmean(float(r[c]) for r in rs)
            out[key][mode] = {
                "frame": med("frame_ms_median"), "raster": mean("raster_ms"), "resolve": mean("resolve_ms"),
                "composite": mean("composite_ms"), "order": mean("order_ms"), "spp": mean("samples_per_pixel"),
                "naive_spp": mean("naive_samples_per_pixel"), "events": mean("events_per_pixel"),
                "segments": mean("segments_per_pixel"), "overflow": mean("overflow_pixels"),
            }
    return out


def fixed_costs(directory):
    """{(volume, w, h): {mode: ns}} from the report's fixed-cost tables (absent in old builds)."""
    out = {}
    try:
        text = open(f"{directory}/report.md").read()
    except OSError:
        return out
    for section in re.split(r"\n## ", text)[1:]:
        head = section.split("\n", 1)[0]
        m = re.match(r"(\S+), (\d+)x(\d+)", head)
        if not m or "fixed ns/pixel" not in section:
            continue
        key = (m.group(1), int(m.group(2)), int(m.group(3)))
        table = section[section.index("| mode | fixed ns/pixel"):]
        for line in table.split("\n")[2:]:
            cells = [c.strip() for c in line.strip("|").split("|")]
            if len(cells) not in (3, 4):  # 4: with the every-pixel column
                break
            out.setdefault(key, {})[cells[0]] = cells[1] if cells[0] != "naive" else cells[-1]
    return out


def fmt(x, digits=1):
    return "n/a" if x is None else f"{x:.{digits}f}"


def main():
    args = sys.argv[1:]
    if not args or any("=" not in a for a in args if a != "--before"):
        sys.exit(__doc__)
    after, before, target = [], [], None
    for a in args:
        if a == "--before":
            target = before
            continue
        (target if target is not None else after).append(a.split("=", 1))
    before_data = {label: load(d) for label, d in before}
    print("| TF | volume | size | step | naive | bbox | octree | sparseleap | speedup | ideal | sparseleap samples % "
          "| lists % of frame | sparseleap / octree | frame / floor | before: naive | before: sparseleap | before: speedup |")
    print("|---" * 17 + "|")
    for label, d in after:
        data = load(d)
        for key in sorted(data):
            vol, w, h, step = key
            m = data[key]
            get = lambda mode: m.get(mode, {}).get("frame")
            sl, nv, oc = m.get("sparseleap"), m.get("naive"), m.get("octree")
            speed = nv["frame"] / sl["frame"] if sl and nv else None
            ideal = sl["naive_spp"] / sl["spp"] if sl and sl["spp"] > 0 else None
            share = 100 * (sl["order"] + sl["raster"] + sl["resolve"]) / sl["frame"] if sl else None
            vs_oct = oc["frame"] / sl["frame"] if sl and oc else None
            floor = None
            if sl and nv and nv["spp"] > 0:
                px = w * h
                ns = nv["composite"] * 1e6 / (nv["spp"] * px)
                floor = sl["frame"] / ((sl["spp"] * px * ns + 40 * px) * 1e-6)
            pct = 100 * sl["spp"] / sl["naive_spp"] if sl and sl["naive_spp"] > 0 else None
            b = before_data.get(label, {}).get(key, {})
            bn, bs = b.get("naive", {}).get("frame"), b.get("sparseleap", {}).get("frame")
            print(f"| {label} | {vol} | {w}x{h} | {step:g} | {fmt(get('naive'))} | {fmt(get('bbox'))} | "
                  f"{fmt(get('octree'))} | {fmt(get('sparseleap'))} | {fmt(speed, 2)} | {fmt(ideal, 1)} | {fmt(pct, 0)} | "
                  f"{fmt(share, 0)} | {fmt(vs_oct, 2)} | {fmt(floor, 2)} | {fmt(bn)} | {fmt(bs)} | "
                  f"{fmt(bn / bs if bn and bs else None, 2)} |")
    print("\nFixed cost per pixel (ns; naive: ns per sample) of a frame in which no ray takes a sample:\n")
    print("| TF | volume | size | naive ns/sample | bbox | octree | sparseleap |\n|---|---|---|---|---|---|---|")
    for label, d in after:
        for key, modes in sorted(fixed_costs(d).items()):
            print(f"| {label} | {key[0]} | {key[1]}x{key[2]} | {modes.get('naive', 'n/a')} | {modes.get('bbox', 'n/a')} | "
                  f"{modes.get('octree', 'n/a')} | {modes.get('sparseleap', 'n/a')} |")


if __name__ == "__main__":
    main()
