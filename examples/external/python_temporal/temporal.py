#!/usr/bin/python3
"""Plain temporal accumulation as an external Denoise Arena denoiser (docs/external-denoisers.md).

One process filters one signal (diffuse or specular) of one sequence. Per pixel it follows the
motion vector into the previous frame, reads the history bilinearly from the taps that lie on the
same mesh, and blends: out = alpha * current + (1 - alpha) * history, alpha = max(alphaMin, 1/h),
h = min(reprojected h + 1, maxHistory), h = 1 where nothing reprojects (SVGF 4.1's moving average,
Falcor's history length). The built-in `temporal` adds Falcor's depth and normal tests and a 3x3
fallback; on a still camera every tap passes both, and the two agree to float rounding (tested).
Needs Debian's python3-numpy.
"""
import json
import sys
import time

import numpy as np


def read_exact(stream, count):
    buffer = bytearray(count)
    view = memoryview(buffer)
    got = 0
    while got < count:
        n = stream.readinto(view[got:])
        if not n:
            raise EOFError(f"input ended after {got} of {count} bytes")
        got += n
    return buffer


def send(stream, header, planes=None):
    stream.write((json.dumps(header) + "\n").encode())
    if planes is not None:
        stream.write(np.ascontiguousarray(planes, dtype="<f4").tobytes())
    stream.flush()


class TemporalAccumulation:
    def __init__(self, width, height, max_history, alpha_min):
        self.w, self.h = width, height
        self.max_history = np.float32(max_history)
        self.alpha_min = np.float32(alpha_min)
        self.history = None  # (accumulated colour, history length, mesh id) of the last frame
        ys, xs = np.mgrid[0:height, 0:width]
        self.xs, self.ys = xs.astype(np.float32), ys.astype(np.float32)

    def reproject(self, color_history, length_history, previous_id, mesh_id, motion_x, motion_y):
        """Bilinear history at each pixel's previous position; taps off-image or on another mesh
        are dropped and the rest renormalised (Falcor: the kept weight must reach 0.01)."""
        # Pixel centre (x + 0.5) moved by the motion vector, back to tap coordinates (- 0.5).
        px = self.xs + motion_x
        py = self.ys + motion_y
        x0 = np.floor(px)
        y0 = np.floor(py)
        fx = px - x0
        fy = py - y0
        x0 = x0.astype(np.int64)
        y0 = y0.astype(np.int64)
        weight_sum = np.zeros_like(fx)
        color = np.zeros((3, self.h, self.w), np.float32)
        length = np.zeros_like(fx)
        for dy, dx, weight in ((0, 0, (1 - fx) * (1 - fy)), (0, 1, fx * (1 - fy)),
                               (1, 0, (1 - fx) * fy), (1, 1, fx * fy)):
            tx, ty = x0 + dx, y0 + dy
            inside = (tx >= 0) & (tx < self.w) & (ty >= 0) & (ty < self.h)
            cx, cy = np.clip(tx, 0, self.w - 1), np.clip(ty, 0, self.h - 1)
            ok = inside & (previous_id[cy, cx] == mesh_id) & (mesh_id >= 0)
            weight = np.where(ok, weight, np.float32(0))
            weight_sum += weight
            color += weight * color_history[:, cy, cx]
            length += weight * length_history[cy, cx]
        valid = weight_sum >= np.float32(0.01)
        safe = np.where(valid, weight_sum, np.float32(1))
        return valid, color / safe, length / safe

    def denoise(self, signal, mesh_id, motion_x, motion_y, reset):
        if reset or self.history is None:
            valid = np.zeros((self.h, self.w), bool)
            reprojected, reprojected_length = signal, np.zeros((self.h, self.w), np.float32)
        else:
            valid, reprojected, reprojected_length = self.reproject(
                *self.history, mesh_id, motion_x, motion_y)
        length = np.where(valid, np.minimum(reprojected_length + np.float32(1), self.max_history),
                          np.float32(1))
        alpha = np.maximum(self.alpha_min, np.float32(1) / np.maximum(length, np.float32(1)))
        out = np.where(valid, alpha * signal + (np.float32(1) - alpha) * reprojected, signal)
        out = out.astype(np.float32)
        self.history = (out, length.astype(np.float32), mesh_id)
        return out


def main():
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    setup = json.loads(stdin.readline())
    if setup.get("protocol") != 1:
        send(stdout, {"type": "error", "message": f"speaks protocol 1, got {setup.get('protocol')}"})
        return 1
    w, h, names = setup["width"], setup["height"], setup["planes"]
    params = setup["params"]
    filt = TemporalAccumulation(w, h, params["maxHistory"], params["alphaMin"])
    send(stdout, {"type": "ready"})
    for line in stdin:
        header = json.loads(line)
        data = np.frombuffer(read_exact(stdin, header["bytes"]), dtype="<f4")
        planes = dict(zip(names, data.reshape(len(names), h, w)))
        start = time.perf_counter()
        signal = np.stack([planes["signal.R"], planes["signal.G"], planes["signal.B"]])
        out = filt.denoise(signal, planes["meshId"], planes["motion.X"], planes["motion.Y"],
                           header["reset"])
        ms = (time.perf_counter() - start) * 1e3
        send(stdout, {"type": "result", "frame": header["frame"], "width": w, "height": h,
                      "channels": 3, "computeMs": ms,
                      "passes": [{"name": "reproject+accumulate", "ms": ms, "tapsPerPixel": 4}]},
             out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
