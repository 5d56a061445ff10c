#!/usr/bin/python3
"""A deliberately faulty external denoiser for tests/external_test.cpp: speaks the frame protocol
(docs/external-denoisers.md) correctly until frame FAIL_AT, then misbehaves as argv[1] says:
  exit       writes to stderr and exits with status 3
  crash      writes to stderr and dies of SIGSEGV
  wrong-size answers a result one pixel narrower than the frame
  short      announces a correct result, sends half the bytes, and exits
  nan        answers a result holding a NaN
  hang       stops answering (sleeps)
  error      answers {"type": "error"} with a message
  garbage    answers a line that is not JSON
  nul        answers a line holding a NUL byte, and writes one to stderr
  slow-report  answers correctly but reports a computeMs of 2e5 (more than the exchange took)
  absurd-time  answers correctly but reports a computeMs of 1e308 (beyond any frame's time)
  huge-taps  answers correctly but reports a pass of 1e308 taps per pixel
  no-ready   hangs before answering the setup
  bad-bytes  writes bytes that are not UTF-8 (a cut character, 0xff) to stderr and exits
  error-code answers {"type": "error"} whose message is a number
  bad-pass   reports a pass with a negative time
  flood      floods its output without reading the frame
  expects-cameras  correct, but reports an error on any frame whose camera is not the frame's size
             or whose previousCamera is not the camera of the frame before (unless reset)
  extra-bytes  sends 12 bytes more than its planes (they land before the next header)
  pass-without-taps  reports a pass with no tapsPerPixel
  exit-at-end  answers every frame, then writes to stderr and exits with status 3 at end of input
  zero-time  answers every frame correctly but reports a computeMs of 0 (a timer not read)
  duplicate-key  answers a header giving computeMs twice
  huge       answers a header whose computeMs is 1e999 (beyond the double range)
  goodbye    answers every frame, then prints a line to stdout at end of input and exits with 0
Plain Python (no numpy): the output is the input signal, so a correct frame is a passthrough."""
import json
import os
import signal
import struct
import sys
import time

FAIL_AT = 1


def main():
    mode = sys.argv[1]
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    setup = json.loads(stdin.readline())
    w, h, planes = setup["width"], setup["height"], len(setup["planes"])
    if mode == "no-ready":
        time.sleep(60)
    def answer(data):
        stdout.write(data)
        stdout.flush()

    answer(b'{"type": "ready"}\n')
    if mode == "flood":
        chunk = b"x" * 65536
        while True:
            stdout.write(chunk)
    last_camera = None
    for line in stdin:
        header = json.loads(line)
        data = stdin.read(header["bytes"])
        frame = header["frame"]
        if mode == "expects-cameras":
            camera, previous = header["camera"], header["previousCamera"]
            problem = None
            if (camera["width"], camera["height"]) != (w, h):
                problem = "camera is %dx%d; expected the frame's %dx%d" % (camera["width"], camera["height"], w, h)
            elif last_camera is not None and not header["reset"] and previous != last_camera:
                problem = "previousCamera is not the camera of the frame before"
            last_camera = camera
            if problem:
                answer((json.dumps({"type": "error", "message": problem}) + "\n").encode())
                continue
        signal_bytes = data[: 3 * w * h * 4]
        # A compute time no exchange can undercut (0.25 ms did, on an idle machine at 16x8: the
        # harness then rightly called it implausible).
        result = {"type": "result", "frame": frame, "width": w, "height": h, "channels": 3,
                  "computeMs": 0.001}
        if mode == "zero-time":
            result["computeMs"] = 0
        if frame >= FAIL_AT:
            if mode == "huge":
                head = json.dumps(result)[:-1] + ', "computeMs": 1e999}'
                head = head.replace('"computeMs": 0.001, ', '')
                answer((head + "\n").encode() + signal_bytes)
                continue
            if mode == "duplicate-key":
                head = json.dumps(result)[:-1] + ', "computeMs": 1e9}'
                answer((head + "\n").encode() + signal_bytes)
                continue
            if mode == "exit":
                sys.stderr.write("faulty: cannot find model weights weights.bin\n")
                sys.stderr.flush()
                os._exit(3)
            if mode == "crash":
                sys.stderr.write("faulty: about to dereference a null pointer\n")
                sys.stderr.flush()
                os.kill(os.getpid(), signal.SIGSEGV)
            if mode == "wrong-size":
                result["width"] = w - 1
                signal_bytes = signal_bytes[: 3 * (w - 1) * h * 4]
            if mode == "short":
                answer((json.dumps(result) + "\n").encode() + signal_bytes[: len(signal_bytes) // 2])
                os._exit(0)
            if mode == "nan":
                sys.stderr.write("faulty: the exposure went to zero\n")
                sys.stderr.flush()
                signal_bytes = struct.pack("<f", float("nan")) + signal_bytes[4:]
            if mode == "hang":
                time.sleep(60)
            if mode == "error":
                answer(b'{"type": "error", "message": "out of GPU memory"}\n')
                continue
            if mode == "bad-bytes":
                sys.stderr.buffer.write("é".encode() * 1500 + b"\xff\x80 weights\n")
                sys.stderr.flush()
                os._exit(4)
            if mode == "error-code":
                answer(b'{"type": "error", "message": 42}\n')
                continue
            if mode == "bad-pass":
                result["passes"] = [{"name": "blur", "ms": -5, "tapsPerPixel": 9}]
            if mode == "garbage":
                answer(b"hello from print debugging\n")
                continue
            if mode == "nul":
                sys.stderr.buffer.write(b"before\0after the NUL\n")
                sys.stderr.flush()
                answer(b"junk\0tail\n")
                continue
            if mode == "extra-bytes":  # 12 bytes more than the planes: read as the next header's
                signal_bytes = signal_bytes + b"\x01" * 12
            if mode == "pass-without-taps":
                result["passes"] = [{"name": "blur", "ms": 0.0005}]
            if mode == "slow-report":
                result["computeMs"] = 2e5
            if mode == "absurd-time":
                result["computeMs"] = 1e308
            if mode == "huge-taps":
                result["passes"] = [{"name": "blur", "ms": 0.0005, "tapsPerPixel": 1e308}]
        answer((json.dumps(result) + "\n").encode() + signal_bytes)
    if mode == "goodbye":
        answer(b"all done, goodbye\n")
    if mode == "exit-at-end":
        sys.stderr.write("faulty: could not free the device buffers\n")
        sys.stderr.flush()
        os._exit(3)
    del planes


if __name__ == "__main__":
    main()
