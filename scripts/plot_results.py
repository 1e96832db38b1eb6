#!/usr/bin/python3
"""The paper's figures from the CSVs scripts/reproduce.sh writes, and their section of RESULTS.md.

Usage: plot_results.py RESULTS_DIR IMAGES_DIR RESULTS_MD COMMIT CORES
Reads RESULTS_DIR/codec_rd.csv, encode_stages.csv, normals_rate.csv, fig5_compressed.csv,
fig5_uncompressed.csv, fig5_budgets.csv, fig5.json, fig6.csv; writes IMAGES_DIR/fig3a.png,
fig4_<scan>.png, fig5.png and the section between <!-- reproduce:begin --> and <!-- reproduce:end -->.
Runs on Debian's python3 with python3-matplotlib.
"""
import csv
import datetime
import json
import os
import platform
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from results_section import replace_section  # noqa: E402

results, images, results_md, commit, cores = sys.argv[1:6]


def rows(name):
    path = os.path.join(results, name)
    return list(csv.DictReader(open(path))) if os.path.exists(path) else []


def interpolate_bpp(points, psnr):
    """bpp at `psnr` on a curve of (bpp, psnr) points, linearly between neighbours; None outside."""
    points = sorted(points, key=lambda p: p[1])
    for (b0, p0), (b1, p1) in zip(points, points[1:]):
        if p0 <= psnr <= p1 and p1 > p0:
            return b0 + (b1 - b0) * (psnr - p0) / (p1 - p0)
    return None


def machine():
    """The CPU's model name and the memory, from /proc, for the section's first line."""
    cpu, mem = platform.processor() or "unknown CPU", ""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal"):
                mem = f", {int(line.split()[1]) / 2**20:.0f} GiB"
                break
    except OSError:
        pass
    return f"{platform.machine()} Linux, {cpu}, {cores} cores{mem}"


rd = rows("codec_rd.csv")
scans = []
for r in rd:
    if r["scan"] not in scans:
        scans.append(r["scan"])
lines = []

# Figure 3a: compression ratio against code-book ratio.
fig, ax = plt.subplots(figsize=(6, 4))
for scan in scans:
    pts = [(float(r["codebook_ratio"]), 96.0 / float(r["bpp"])) for r in rd
           if r["scan"] == scan and r["codec"] == "sspc" and r["codebook_ratio"]]
    if pts:
        pts.sort()
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=scan)
ax.set_xlabel("code-book ratio (patches / code words)")
ax.set_ylabel("compression ratio (96 bits per point / bpp)")
ax.set_title("Figure 3a: compression against self-similarity")
ax.grid(True, alpha=0.3)
ax.legend()
fig.tight_layout()
fig.savefig(os.path.join(images, "fig3a.png"), dpi=100)
plt.close(fig)

# Figure 4: rate-distortion, sspc and Draco on the same axes, paper PSNR and D1 PSNR; where the
# file has normals, also each codec's rate with them stored (same positions, so same PSNR).
normals = rows("normals_rate.csv")
with_normals = {(r["scan"], r["codec"], r["setting"]): float(r["total_bpp"]) for r in normals}
headline = []
for scan in scans:
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for codec, colour, marker in (("sspc", "C0", "o"), ("draco", "C1", "s")):
        runs = sorted((float(r["bpp"]), float(r["psnr"]), float(r["d1_psnr"]), r["setting"]) for r in rd
                      if r["scan"] == scan and r["codec"] == codec)
        if not runs:
            continue
        for ax, k in ((axes[0], 1), (axes[1], 2)):
            ax.plot([p[0] for p in runs], [p[k] for p in runs], marker + "-", color=colour,
                    label=f"{codec}, positions")
            both = sorted((with_normals[(scan, codec, p[3])], p[k]) for p in runs
                          if (scan, codec, p[3]) in with_normals)
            if both:
                ax.plot([p[0] for p in both], [p[1] for p in both], marker + ":", color=colour, mfc="none",
                        label=f"{codec}, with normals")
    for ax, metric in zip(axes, ("PSNR (paper) dB", "D1 PSNR dB")):
        ax.set_xlabel("bits per point")
        ax.set_ylabel(metric)
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.suptitle(f"Figure 4: {scan}")
    fig.tight_layout()
    fig.savefig(os.path.join(images, f"fig4_{scan}.png"), dpi=100)
    plt.close(fig)
    # sspc's bits against Draco's at equal PSNR, at each sspc rate inside Draco's range.
    draco = [(float(r["bpp"]), float(r["psnr"])) for r in rd if r["scan"] == scan and r["codec"] == "draco"]
    for r in rd:
        if r["scan"] != scan or r["codec"] != "sspc":
            continue
        d = interpolate_bpp(draco, float(r["psnr"]))
        headline.append((scan, r["setting"], float(r["bpp"]), float(r["psnr"]), float(r["d1_psnr"]), d))

lines += ["### Figure 4: rate–distortion against Draco", ""]
lines += [f"![Figure 4, {s}](images/fig4_{s}.png)" for s in scans]
lines += ["", "sspc's rate against Draco's at the same paper PSNR (Draco's curve interpolated between its "
          "measured rates; blank outside them):", "",
          "| scan | sspc | bpp | PSNR dB | D1 dB | Draco bpp at that PSNR | sspc / Draco |", "|---|---|---:|---:|---:|---:|---:|"]
for scan, setting, bpp, psnr, d1, d in headline:
    ratio = f"{bpp / d:.2f}" if d else ""
    lines.append(f"| {scan} | {setting} | {bpp:.3f} | {psnr:.2f} | {d1:.2f} | {f'{d:.3f}' if d else ''} | {ratio} |")
spans = []
for scan in scans:
    ratios = sorted(bpp / d for s, _, bpp, _, _, d in headline if s == scan and d)
    if ratios:
        spans.append(f"{scan} {ratios[0]:.2f}–{ratios[-1]:.2f} (median {ratios[len(ratios) // 2]:.2f})")
if spans:
    lines += ["", "sspc / Draco at equal PSNR, over the rates where both were measured: " + "; ".join(spans) + "."]

if normals:
    lines += ["", "Normals: the rates above are positions only (sspc's default; Draco with `--skip NORMAL`); the "
              "decoders re-estimate normals. Stored (sspc `--store-normals`, Draco's default 8-bit normals) they "
              "cost the following; the positions, and so the PSNR, are the same either way (dotted curves "
              "above):", "",
              "| scan | codec | setting | positions bpp | with normals bpp | normals bpp |", "|---|---|---|---:|---:|---:|"]
    for r in normals:
        lines.append(f'| {r["scan"]} | {r["codec"]} | {r["setting"]} | {float(r["positions_bpp"]):.3f} | '
                     f'{float(r["total_bpp"]):.3f} | {float(r["total_bpp"]) - float(r["positions_bpp"]):.3f} |')

lines = ["### Figure 3a: compression ratio against code-book ratio", "", "![Figure 3a](images/fig3a.png)", "",
         "Each point is one level (0: most detail … 9: smallest file). The compression ratio takes 96 bits per "
         "point (three floats) as the uncompressed size.", ""] + lines

# Encoding time per stage.
stages = rows("encode_stages.csv")
if stages:
    lines += ["", "### Encoding time per stage", "",
              "Wall-clock seconds of `sspc encode` at the default level on this machine's cores, from its "
              "`--json`. The paper reports \"several hours\" for its slowest models and 30 minutes for "
              "28M points.", "",
              "| scan | points | read | normals | centres | descriptors | clustering | writing | total | points/s |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in stages:
        lines.append("| " + " | ".join([r["scan"], r["points"]] + [f'{float(r[k]):.2f}' for k in (
            "read", "normals", "centres", "descriptors", "clustering", "writing", "total")] +
            [f'{float(r["points_per_s"]):.0f}']) + " |")

# Figure 5: frame times along a camera path, compressed against paged uncompressed; beside it the
# uncompressed path's median frame time at other memory budgets.
f5c, f5u = rows("fig5_compressed.csv"), rows("fig5_uncompressed.csv")
if f5c and f5u:
    meta = json.load(open(os.path.join(results, "fig5.json")))
    med = lambda v: sorted(v)[len(v) // 2]
    tc = med([float(r["render_seconds"]) for r in f5c])
    tu = med([float(r["render_seconds"]) for r in f5u])
    read_u = sum(int(r["bytes_read"]) for r in f5u) / 2**20
    budgets = {meta["budget_mib"]: f5u}
    for r in rows("fig5_budgets.csv"):
        budgets.setdefault(int(r["budget_mib"]), []).append(r)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), gridspec_kw={"width_ratios": [3, 2]})
    ax = axes[0]
    ax.plot([int(r["frame"]) for r in f5u], [float(r["render_seconds"]) for r in f5u], "s--",
            label=f'uncompressed, paged ({meta["uncompressed_mib"]:.0f} MiB scene)')
    ax.plot([int(r["frame"]) for r in f5c], [float(r["render_seconds"]) for r in f5c], "o-",
            label=f'compressed ({meta["compressed_mib"]:.0f} MiB scene)')
    ax.set_xlabel("frame")
    ax.set_ylabel("render seconds")
    ax.set_title(f'{meta["scan"]}, memory budget {meta["budget_mib"]} MiB')
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax = axes[1]
    sizes = sorted(budgets)
    ax.plot(sizes, [med([float(r["render_seconds"]) for r in budgets[b]]) for b in sizes], "s--",
            label="uncompressed, paged")
    ax.axhline(tc, color="C1", label="compressed, in memory")
    ax.axvline(meta["uncompressed_mib"], color="gray", linestyle=":", label="uncompressed scene size")
    ax.set_xlabel("memory budget MiB")
    ax.set_ylabel("median frame seconds")
    ax.set_title("frame time against the budget")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.suptitle("Figure 5: rendering within a memory budget")
    fig.tight_layout()
    fig.savefig(os.path.join(images, "fig5.png"), dpi=100)
    plt.close(fig)
    lines += ["", "### Figure 5: rendering within a memory budget", "", "![Figure 5](images/fig5.png)", "",
              f'{meta["scan"]} ({meta["points"]:,} points), {len(f5c)} frames of {meta["size"]} along a camera path '
              f'circling above it, {meta["threads"]} threads, memory budget {meta["budget_mib"]} MiB. The '
              f'uncompressed scene needs {meta["uncompressed_mib"]:.0f} MiB (float points and normals and their '
              f'grid), so it is paged in from a file through a cache of the budget; it read {read_u:.0f} MiB over '
              f'the path. The compressed scene (level {meta["level"]}, {meta["bpp"]:.2f} bpp) holds '
              f'{meta["compressed_mib"]:.0f} MiB and {"fits" if meta.get("compressed_within_budget", True) else "does NOT fit"}. Median frame: compressed {tc:.2f} s, uncompressed '
              f'{tu:.2f} s: a speed-up of {tu / tc:.2f}.']
    if len(budgets) > 1:
        lines += ["", "The same path, uncompressed, at larger budgets; at one above the scene's size the cache holds it "
                  "all after the first frames, as an in-memory renderer would:", "",
                  "| budget MiB | median frame s | read over the path MiB | speed-up of compressed |",
                  "|---:|---:|---:|---:|"]
        for b in sizes:
            m = med([float(r["render_seconds"]) for r in budgets[b]])
            read = sum(int(r["bytes_read"]) for r in budgets[b]) / 2**20
            lines.append(f"| {b} | {m:.2f} | {read:.0f} | {m / tc:.2f} |")
        # What paging cost per frame against the scene held whole, and the read rate below which
        # the compressed scene is ahead.
        whole = [b for b in sizes if b >= meta["uncompressed_mib"]]
        if whole:
            tm = med([float(r["render_seconds"]) for r in budgets[whole[-1]]])
            per_frame = med([int(r["bytes_read"]) for r in f5u]) / 2**20
            text = (f"With the whole scene cached ({whole[-1]} MiB) a frame takes {tm:.2f} s. At "
                    f'{meta["budget_mib"]} MiB the paged renderer reads a median {per_frame:.0f} MiB a frame ')
            if tu > tm:
                text += (f"and takes {tu - tm:.2f} s longer: the page file arrives at about "
                         f"{per_frame / (tu - tm):.0f} MiB/s on this machine. ")
            else:
                text += "at no measurable cost in time. "
            if tc > tm:
                text += (f"The compressed scene renders in {tc / tm:.1f}× the in-memory time, so it is ahead of "
                         f"paging wherever pages arrive slower than about {per_frame / (tc - tm):.0f} MiB/s.")
            else:
                text += "The compressed scene renders faster than the uncompressed one even held in memory."
            lines += ["", text]

# Figure 6: code-word renders at 4 rates.
f6 = rows("fig6.csv")
if f6:
    lines += ["", "### Figure 6: code words at four rates", "",
              "Each colour is one code word; a colour seen twice is one code word instanced twice.", "",
              "| " + " | ".join(r["setting"] for r in f6) + " |", "|" + "---|" * len(f6),
              "| " + " | ".join(f'![{r["setting"]}](images/{r["image"]})' for r in f6) + " |",
              "| " + " | ".join(f'{float(r["bpp"]):.2f} bpp, {float(r["psnr"]):.1f} dB' for r in f6) + " |"]

header = [f"Made by `scripts/reproduce.sh` on {datetime.date.today()} at commit {commit}, on {machine()}; "
          "raw CSVs in `docs/results/`.", ""]
replace_section(results_md, "reproduce", "The paper's figures, reproduced", header + lines)
print(f"wrote the figures in {images} and the section in {results_md}")
