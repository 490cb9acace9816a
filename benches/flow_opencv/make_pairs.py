"""Writes synthetic frame pairs with exact ground-truth flow for the flow benchmark.

Each scene is a textured background under a global affine motion (shift plus expansion
about a focus of expansion) with textured rectangular "vehicles" that move and scale about
their own centres. Both frames are rendered from 2x supersampled textures (bicubic sampling
at the exactly warped coordinates, then area down-sampling), with independent Gaussian
noise, so the ground truth is exact up to rendering noise.

Output folder layout (read by examples/flow_bench.rs and opencv_dis.py):
    manifest.json                      list of pairs: name, frame files, gt file, boxes
    <name>_0.png, <name>_1.png         8-bit grey frames
    <name>_gt.png                      KITTI 16-bit flow: R,G = 64*flow + 2^15, B = valid

Flow convention: I0(x) ~ I1(x + f(x)), f = (dx, dy) in pixels, stored at frame 0's grid.
Usage: python make_pairs.py OUT_DIR [--width 800 --height 600]
"""
import argparse
import json
import os

import cv2
import numpy as np

SS = 2  # supersampling factor
PAD = 200  # texture margin (output pixels) so warps never sample outside


def texture(h, w, rng, kind):
    """Band-limited multi-scale noise plus hard-edged rectangles and lines (float32)."""
    tex = np.zeros((h, w), np.float32)
    for sigma, amp in [(64, 50), (24, 35), (8, 25), (3, 18), (1.2, 10)]:
        n = cv2.GaussianBlur(rng.standard_normal((h, w)).astype(np.float32), (0, 0), sigma)
        tex += amp * n / (n.std() + 1e-6)
    for _ in range(60 if kind == "bg" else 25):
        x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
        rw, rh = int(rng.integers(w // 40, w // 6)), int(rng.integers(h // 40, h // 6))
        cv2.rectangle(tex, (x0, y0), (x0 + rw, y0 + rh), float(rng.uniform(-60, 60)),
                      -1 if rng.random() < 0.6 else 3)
    for _ in range(20 if kind == "bg" else 8):
        p1 = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        p2 = (int(rng.integers(0, w)), int(rng.integers(0, h)))
        cv2.line(tex, p1, p2, float(rng.uniform(-70, 70)), int(rng.integers(2, 8)))
    tex = cv2.GaussianBlur(tex, (0, 0), 1.0)
    tex += (128 if kind == "bg" else 110) - tex.mean()
    return np.clip(tex, 0, 255).astype(np.float32)


class Scene:
    def __init__(self, name, w, h, shift=(0.0, 0.0), expansion=0.0, foe=None, vehicles=(),
                 gain=1.0, seed=0, noise=1.5):
        self.name, self.w, self.h = name, w, h
        self.shift = np.asarray(shift, np.float64)
        self.k = expansion
        self.foe = np.asarray(foe if foe is not None else (w / 2, h / 2), np.float64)
        self.vehicles = list(vehicles)  # dicts: box (x0, y0, x1, y1), scale, shift
        self.gain, self.seed, self.noise = gain, seed, noise

    def bg_forward(self, x, y):
        return (self.foe[0] + (1 + self.k) * (x - self.foe[0]) + self.shift[0],
                self.foe[1] + (1 + self.k) * (y - self.foe[1]) + self.shift[1])

    def bg_inverse(self, x, y):
        return (self.foe[0] + (x - self.shift[0] - self.foe[0]) / (1 + self.k),
                self.foe[1] + (y - self.shift[1] - self.foe[1]) / (1 + self.k))

    @staticmethod
    def centre(v):
        x0, y0, x1, y1 = v["box"]
        return (x0 + x1) / 2.0, (y0 + y1) / 2.0

    def veh_forward(self, v, x, y):
        cx, cy = self.centre(v)
        return cx + v["shift"][0] + v["scale"] * (x - cx), cy + v["shift"][1] + v["scale"] * (y - cy)

    def veh_inverse(self, v, x, y):
        cx, cy = self.centre(v)
        return cx + (x - cx - v["shift"][0]) / v["scale"], cy + (y - cy - v["shift"][1]) / v["scale"]

    @staticmethod
    def inside(v, x, y):
        x0, y0, x1, y1 = v["box"]
        return (x >= x0) & (x < x1) & (y >= y0) & (y < y1)

    def render(self):
        rng = np.random.default_rng(self.seed)
        H, W = self.h * SS, self.w * SS
        bg = texture(H + 2 * PAD * SS, W + 2 * PAD * SS, rng, "bg")
        fg = texture(H + 2 * PAD * SS, W + 2 * PAD * SS, rng, "obj")
        Y, X = np.mgrid[0:H, 0:W].astype(np.float64)
        xl, yl = (X - (SS - 1) / 2.0) / SS, (Y - (SS - 1) / 2.0) / SS

        def sample(tex, sx, sy):
            mx = (sx * SS + (SS - 1) / 2.0 + PAD * SS).astype(np.float32)
            my = (sy * SS + (SS - 1) / 2.0 + PAD * SS).astype(np.float32)
            return cv2.remap(tex, mx, my, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)

        f0 = sample(bg, xl, yl)
        for v in self.vehicles:
            f0 = np.where(self.inside(v, xl, yl), sample(fg, xl, yl), f0)
        f1 = sample(bg, *self.bg_inverse(xl, yl))
        for v in self.vehicles:
            ox, oy = self.veh_inverse(v, xl, yl)
            f1 = np.where(self.inside(v, ox, oy), sample(fg, ox, oy), f1)
        f0 = cv2.resize(f0, (self.w, self.h), interpolation=cv2.INTER_AREA)
        f1 = cv2.resize(f1, (self.w, self.h), interpolation=cv2.INTER_AREA) * self.gain
        f0 = f0 + rng.standard_normal(f0.shape) * self.noise
        f1 = f1 + rng.standard_normal(f1.shape) * self.noise
        i0 = np.clip(np.rint(f0), 0, 255).astype(np.uint8)
        i1 = np.clip(np.rint(f1), 0, 255).astype(np.uint8)

        yy, xx = np.mgrid[0:self.h, 0:self.w].astype(np.float64)
        fx, fy = self.bg_forward(xx, yy)
        gt = np.stack([fx - xx, fy - yy], -1)
        valid = (fx >= 0) & (fx <= self.w - 1) & (fy >= 0) & (fy <= self.h - 1)
        on_vehicle = np.zeros_like(valid)
        for v in self.vehicles:
            on_vehicle |= self.inside(v, xx, yy)
        occluded = np.zeros_like(valid)
        for v in self.vehicles:
            m = self.inside(v, xx, yy)
            ox, oy = self.veh_forward(v, xx, yy)
            gt[m] = np.stack([ox - xx, oy - yy], -1)[m]
            # Background pixels that land on a vehicle in frame 1 are occluded.
            ix, iy = self.veh_inverse(v, fx, fy)
            occluded |= ~on_vehicle & self.inside(v, ix, iy)
            in_frame = (ox >= 0) & (ox <= self.w - 1) & (oy >= 0) & (oy <= self.h - 1)
            valid = np.where(m, in_frame, valid)
        valid &= ~occluded
        return i0, i1, gt.astype(np.float32), valid


def scenes(w, h):
    sx, sy = w / 800.0, h / 600.0  # scene layouts are defined on 800x600

    def box(x0, y0, x1, y1):
        return (x0 * sx, y0 * sy, x1 * sx, y1 * sy)

    return [
        Scene("S1_shift", w, h, shift=(1.37, -0.62), seed=1),
        Scene("S2_shift_vehicle", w, h, shift=(2.4, 0.7), seed=2,
              vehicles=[dict(box=box(430, 250, 670, 430), scale=1.06, shift=(-1.5, 0.8))]),
        Scene("S3_expansion_vehicle", w, h, expansion=0.02, foe=(400 * sx, 260 * sy), seed=3,
              vehicles=[dict(box=box(300, 230, 560, 430), scale=1.10, shift=(3.0, 1.0))]),
        Scene("S4_large_shift", w, h, shift=(12.6, -4.3), seed=4,
              vehicles=[dict(box=box(120, 200, 340, 380), scale=1.15, shift=(6.0, 2.0))]),
        Scene("S5_brightness", w, h, expansion=0.02, foe=(400 * sx, 260 * sy), gain=1.05, seed=3,
              vehicles=[dict(box=box(300, 230, 560, 430), scale=1.10, shift=(3.0, 1.0))]),
        Scene("S6_small_vehicles", w, h, expansion=0.015, foe=(400 * sx, 280 * sy), seed=6,
              vehicles=[dict(box=box(180, 300, 252, 354), scale=1.08, shift=(-2.0, 0.5)),
                        dict(box=box(420, 260, 492, 314), scale=1.04, shift=(1.0, 0.0)),
                        dict(box=box(600, 330, 680, 390), scale=1.12, shift=(4.0, 1.5))]),
    ]


def write_kitti(path, flow, valid):
    enc = np.clip(np.rint(flow * 64.0 + 32768.0), 0, 65535).astype(np.uint16)
    bgr = np.stack([valid.astype(np.uint16), enc[..., 1], enc[..., 0]], -1)
    cv2.imwrite(path, bgr)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--width", type=int, default=800)
    ap.add_argument("--height", type=int, default=600)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    pairs = []
    for s in scenes(a.width, a.height):
        i0, i1, gt, valid = s.render()
        names = [f"{s.name}_0.png", f"{s.name}_1.png", f"{s.name}_gt.png"]
        cv2.imwrite(os.path.join(a.out, names[0]), i0)
        cv2.imwrite(os.path.join(a.out, names[1]), i1)
        write_kitti(os.path.join(a.out, names[2]), gt, valid)
        pairs.append(dict(name=s.name, frame0=names[0], frame1=names[1], flow=names[2],
                          boxes=[list(map(float, v["box"])) for v in s.vehicles]))
        print(f"{s.name}: |gt| mean {np.linalg.norm(gt, axis=-1).mean():.2f}, "
              f"valid {valid.mean() * 100:.1f}%", flush=True)
    with open(os.path.join(a.out, "manifest.json"), "w") as f:
        json.dump(dict(source="make_pairs.py", truth_everywhere=True, width=a.width, height=a.height,
                       pairs=pairs), f, indent=1)


if __name__ == "__main__":
    main()
