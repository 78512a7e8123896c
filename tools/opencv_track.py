#!/usr/bin/env python3
"""The mesopush tracking pipeline re-done with OpenCV, as a speed and sanity reference.

Same steps as host/vision/src (paper section IV): background subtraction normalised by the
plate's light (a quadratic fitted to the bright background), Otsu threshold, removal of the
probe by a morphological opening with a disc wider than the needle (two chamfer distance
transforms, as ours), then the peg's centroid
and orientation from coverage-weighted second moments (cv2.moments on the darkening image
over the peg plus a 3 px band). Times only the per-frame processing (frames are loaded
first), on one thread (cv2.setNumThreads(1)) unless --threads is given. Like mesopush, the
distance transforms and the labelling run on the mask's bounding box grown by a pixel
(`--full-frame` for the whole frame, `--both` to time both modes in one run).

    pip install opencv-python-headless numpy
    python3 tools/opencv_track.py FRAMES_DIR --background bg.png [--out pose.csv]
"""

import argparse
import csv
import math
import pathlib
import sys
import time

import cv2
import numpy as np

FIELD_UM = (3370.0, 2520.0)
OPEN_RADIUS_PX = 20
BAND_PX = 3


def fit_light(bg):
    """Quadratic fit to the bright plate (three refits dropping the walls); returns 1/light."""
    h, w = bg.shape
    ys, xs = np.mgrid[0:h:4, 0:w:4]
    x = (xs + 0.5) / w - 0.5
    y = (ys + 0.5) / h - 0.5
    a = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1).reshape(-1, 6)
    v = bg[::4, ::4].reshape(-1).astype(np.float64)
    keep = v > 0.6 * v.max()
    for _ in range(4):
        coef, *_ = np.linalg.lstsq(a[keep], v[keep], rcond=None)
        keep = v > 0.85 * (a @ coef)
    yy, xx = np.mgrid[0:h, 0:w]
    x = (xx + 0.5) / w - 0.5
    y = (yy + 0.5) / h - 0.5
    light = coef[0] + coef[1] * x + coef[2] * y + coef[3] * x * x + coef[4] * x * y + coef[5] * y * y
    return (1.0 / np.maximum(light, 1.0)).astype(np.float32)


class Tracker:
    def __init__(self, bg, sx, sy, crop=True):
        self.crop = crop
        self.bg = bg.astype(np.float32)
        self.inv_light = fit_light(bg)
        self.sx, self.sy = sx, sy
        self.band = cv2.getStructuringElement(cv2.MORPH_RECT, (2 * BAND_PX + 1, 2 * BAND_PX + 1))

    def measure(self, frame):
        dark_full = cv2.multiply(cv2.subtract(self.bg, frame.astype(np.float32)), self.inv_light)
        dark8 = cv2.convertScaleAbs(dark_full, alpha=255.0)
        thr, mask_full = cv2.threshold(dark8, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        if thr < 0.12 * 255:
            _, mask_full = cv2.threshold(dark8, int(0.12 * 255), 255, cv2.THRESH_BINARY)
        h, w = mask_full.shape
        # As ours: the distance transforms, the labelling and the moments run on the mask's
        # bounding box, grown by the moments' band and a pixel (exact: every distance and
        # every weighted pixel they need lies inside it); --full-frame runs them on the whole
        # frame, as this script first did.
        ox, oy, ex, ey = 0, 0, w, h
        if self.crop:
            bx, by, bw_, bh_ = cv2.boundingRect(mask_full)
            if bw_ == 0:
                return None, None
            g = BAND_PX + 2
            ox, oy = max(bx - g, 0), max(by - g, 0)
            ex, ey = min(bx + bw_ + g, w), min(by + bh_ + g, h)
        mask, dark = mask_full[oy:ey, ox:ex], dark_full[oy:ey, ox:ex]
        # opening by a disc of OPEN_RADIUS_PX via two chamfer distance transforms (as ours):
        # the core lies deeper than the radius; the opening is what lies within it of the core
        depth = cv2.distanceTransform(mask, cv2.DIST_L2, 3)
        outside_core = np.where(depth > OPEN_RADIUS_PX, np.uint8(0), np.uint8(255))
        to_core = cv2.distanceTransform(outside_core, cv2.DIST_L2, 3)
        opened = np.where(to_core <= OPEN_RADIUS_PX + 0.34, mask, np.uint8(0))
        thin = cv2.subtract(mask, opened)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(thin, connectivity=8)
        x, y, bw, bh, area = (stats[:, i] for i in range(5))
        # the frame's border, in the crop's coordinates
        on_border = (x + ox == 0) | (y + oy == 0) | (x + ox + bw == w) | (y + oy + bh == h)
        keep = (area >= OPEN_RADIUS_PX ** 2 // 2) | (on_border & (area >= 12))
        keep[0] = False
        needle = np.where(keep[labels], np.uint8(255), np.uint8(0))
        tip = None
        if keep.any():
            i = int(np.argmax(np.where(keep, area, -1)))
            bx, by = x[i], y[i]
            ys, xs = np.nonzero(labels[by:by + bh[i], bx:bx + bw[i]] == i)
            xs, ys = xs + bx + ox, ys + by + oy
            edge = (xs == 0) | (ys == 0) | (xs == w - 1) | (ys == h - 1)
            if edge.any():
                ex_, ey_ = xs[edge].mean(), ys[edge].mean()
                k = np.argmax((xs - ex_) ** 2 + (ys - ey_) ** 2)
                tip = ((xs[k] + 0.5) * self.sx, (ys[k] + 0.5) * self.sy)
        rest = cv2.subtract(mask, needle)
        n, labels, stats, _ = cv2.connectedComponentsWithStats(rest, connectivity=8)
        if n < 2:
            return None, tip
        hc, wc = mask.shape
        peg_label = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        x, y, bw, bh, _ = stats[peg_label]
        x0, y0 = max(x - BAND_PX - 1, 0), max(y - BAND_PX - 1, 0)
        x1, y1 = min(x + bw + BAND_PX + 1, wc), min(y + bh + BAND_PX + 1, hc)
        peg = (labels[y0:y1, x0:x1] == peg_label).astype(np.uint8)
        inner = cv2.erode(peg, self.band)
        contrast = float(np.median(dark[y0:y1, x0:x1][inner > 0])) if inner.any() else 0.5
        near_needle = cv2.dilate(needle[y0:y1, x0:x1], self.band)
        support = cv2.dilate(peg, self.band) > 0
        support &= (near_needle == 0) | (peg > 0)
        support &= (rest[y0:y1, x0:x1] == 0) | (peg > 0)
        weights = np.where(support, np.clip(dark[y0:y1, x0:x1] / contrast, -0.5, 1.5), 0.0)
        m = cv2.moments(weights.astype(np.float32))
        if m["m00"] <= 0:
            return None, tip
        cx, cy = m["m10"] / m["m00"], m["m01"] / m["m00"]
        mu20 = m["mu20"] * self.sx * self.sx
        mu02 = m["mu02"] * self.sy * self.sy
        mu11 = m["mu11"] * self.sx * self.sy
        theta = 0.5 * math.atan2(2 * mu11, mu20 - mu02)
        pose = ((ox + x0 + cx + 0.5) * self.sx, (oy + y0 + cy + 0.5) * self.sy, theta)
        return pose, tip


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("frames_dir", type=pathlib.Path)
    ap.add_argument("--background", type=pathlib.Path, required=True)
    ap.add_argument("--out", type=pathlib.Path)
    ap.add_argument("--threads", type=int, default=1, help="OpenCV threads (default 1: one core)")
    ap.add_argument("--repeat", type=int, default=5, help="passes over the frames for timing")
    ap.add_argument("--full-frame", action="store_true",
                    help="distance transforms and labelling on the whole frame (default: on the "
                         "mask's bounding box, as mesopush does)")
    ap.add_argument("--both", action="store_true", help="also time the other mode, in the same run")
    args = ap.parse_args()
    cv2.setNumThreads(args.threads)
    bg = cv2.imread(str(args.background), cv2.IMREAD_GRAYSCALE)
    if bg is None:
        sys.exit(f"{args.background}: cannot read the background")
    bg_resolved = args.background.resolve()
    paths = sorted(p for p in args.frames_dir.glob("*.png") if p.resolve() != bg_resolved)
    if not paths:
        sys.exit(f"{args.frames_dir}: no PNG frames")
    frames = [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in paths]
    h, w = bg.shape
    tracker = Tracker(bg, FIELD_UM[0] / w, FIELD_UM[1] / h, crop=not args.full_frame)
    results = [tracker.measure(f) for f in frames]
    runs = args.repeat * len(frames)

    def timed(t):
        start, cpu_start = time.perf_counter(), time.process_time()
        for _ in range(args.repeat):
            for f in frames:
                t.measure(f)
        return 1e3 * (time.perf_counter() - start) / runs, 1e3 * (time.process_time() - cpu_start) / runs

    per_frame_ms, cpu_ms = timed(tracker)
    if args.out:
        with open(args.out, "w", newline="") as fh:
            out = csv.writer(fh)
            out.writerow(["frame", "x_um", "y_um", "theta_rad", "probe_tip_x_um", "probe_tip_y_um"])
            for p, (pose, tip) in zip(paths, results):
                row = [p.stem]
                row += ["", "", ""] if pose is None else [f"{pose[0]:.3f}", f"{pose[1]:.3f}", f"{pose[2]:.6f}"]
                row += ["", ""] if tip is None else [f"{tip[0]:.3f}", f"{tip[1]:.3f}"]
                out.writerow(row)
    mode = "whole frame" if args.full_frame else "bounding-box crop, as mesopush"
    print(f"opencv {cv2.__version__}: {len(frames)} frames {w}x{h}, {per_frame_ms:.3f} ms/frame wall, "
          f"{cpu_ms:.3f} ms/frame CPU ({args.threads} thread(s), {args.repeat} passes, {mode})")
    if args.both:
        other = Tracker(bg, FIELD_UM[0] / w, FIELD_UM[1] / h, crop=args.full_frame)
        wall2, cpu2 = timed(other)
        mode2 = "bounding-box crop, as mesopush" if args.full_frame else "whole frame"
        print(f"opencv {cv2.__version__}: {wall2:.3f} ms/frame wall, {cpu2:.3f} ms/frame CPU ({mode2})")


if __name__ == "__main__":
    main()
