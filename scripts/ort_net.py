#!/usr/bin/env python3
"""U²-Net-p in onnxruntime behind a pipe, for long evaluation runs of the CLI
(`SHAPETRACK_EVAL_NET="python3 scripts/ort_net.py MODEL" shapetrack detect-eval … --net-cache DIR`,
see src/bin/shapetrack/netcache.rs). Reads 3·320·320 little-endian f32 from stdin, writes the
first output's 320·320 f32 to stdout, until stdin closes. Needs `pip install onnxruntime numpy`
(in a venv). One thread, like the CLI."""
import sys

import numpy as np
import onnxruntime as ort

SIDE = 320
opts = ort.SessionOptions()
opts.intra_op_num_threads = 1
opts.inter_op_num_threads = 1
sess = ort.InferenceSession(sys.argv[1], opts, providers=["CPUExecutionProvider"])
name = sess.get_inputs()[0].name
stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
n = 3 * SIDE * SIDE * 4
while True:
    buf = stdin.read(n)
    if len(buf) < n:
        break
    x = np.frombuffer(buf, dtype="<f4").reshape(1, 3, SIDE, SIDE)
    y = sess.run(None, {name: x})[0]
    stdout.write(np.ascontiguousarray(y, dtype="<f4").reshape(-1).tobytes())
    stdout.flush()
