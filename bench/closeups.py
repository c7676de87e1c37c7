#!/usr/bin/env python3
"""Close-ups for a person to compare: the same crop of several frames side by side, each
enlarged by pixel replication (no smoothing, so every pixel stays visible), labelled, on a
mid-grey ground, in rows of `--columns` panels. Used for
`analysis/antialiasing/closeups-M2-S1-T1-A2.png` (BENCHMARKS.md, "Morphological
antialiasing") and `analysis/media/lighting-models-*.png` ("Participating media"); needs Pillow.

    python3 bench/closeups.py --crop 250,110,160,120 --scale 3 --out OUT.png \
        "1 point per pixel=a.png" "1 point + MLAA=b.png" "4 x 4 points=c.png"
"""

import argparse

from PIL import Image, ImageDraw

GREY = (128, 128, 128)
LABEL_HEIGHT = 30
GAP = 20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--crop", required=True, help="x,y,width,height in pixels of every frame")
    parser.add_argument("--scale", type=int, default=3, help="enlargement, by pixel replication")
    parser.add_argument("--columns", type=int, default=0, help="panels per row (default: all in one row)")
    parser.add_argument("--out", required=True, help="the figure (PNG)")
    parser.add_argument("panels", nargs="+", help="LABEL=FILE, left to right")
    args = parser.parse_args()
    x, y, w, h = (int(v) for v in args.crop.split(","))
    panels = []
    for item in args.panels:
        label, _, path = item.partition("=")
        if not path:
            parser.error(f"panel `{item}`: expected LABEL=FILE")
        frame = Image.open(path).convert("RGB")
        if x + w > frame.width or y + h > frame.height:
            parser.error(f"{path}: the crop {args.crop} leaves the {frame.width}x{frame.height} frame")
        panels.append((label, frame.crop((x, y, x + w, y + h)).resize((w * args.scale, h * args.scale), Image.NEAREST)))
    pw, ph = w * args.scale, h * args.scale
    columns = args.columns if args.columns > 0 else len(panels)
    rows = -(-len(panels) // columns)
    row_height = ph + LABEL_HEIGHT
    figure = Image.new("RGB", (columns * pw + (columns - 1) * GAP, rows * row_height + (rows - 1) * GAP), GREY)
    draw = ImageDraw.Draw(figure)
    for i, (label, image) in enumerate(panels):
        left, top = (i % columns) * (pw + GAP), (i // columns) * (row_height + GAP)
        figure.paste(image, (left, top + LABEL_HEIGHT))
        draw.text((left + 5, top + 8), label, fill=(20, 20, 20))
    figure.save(args.out)


if __name__ == "__main__":
    main()
