"""Replaces one marked section of docs/RESULTS.md, for the scripts that measure things.

Each measuring script (rd_codec.sh, bench_render.sh, plot_results.py) owns the lines between
<!-- NAME:begin --> and <!-- NAME:end -->; the rest of the file is prose kept by hand. A
missing section is appended under its heading. The file is written to a temporary beside it and
renamed, so an interrupted run leaves the old file whole.
"""
import os


def replace_section(path, name, heading, lines):
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    text = open(path).read() if os.path.exists(path) else "# Results\n"
    if begin not in text:
        text += f"\n## {heading}\n\n{begin}\n{end}\n"
    head, rest = text.split(begin, 1)
    if end not in rest:
        raise SystemExit(f"{path}: {begin} without {end}")
    tail = rest.split(end, 1)[1]
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(head + begin + "\n" + "\n".join(lines) + "\n" + end + tail)
    os.replace(tmp, path)
