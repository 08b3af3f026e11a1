#!/usr/bin/env python3
"""U²-Net-p in onnxruntime behind a pipe, for long evaluation runs of the CLI
(`SHAPETRACK_EVAL_NET="python3 scripts/ort_net.py MODEL" shapetrack detect-eval … --net-cache DIR`,
see src/bin/shapetrack/netcache.rs). Reads, until stdin closes, a side as a little-endian u32
then 3·side·side little-endian f32, and writes the first output's side·side f32 to stdout. The
model file declares 320×320; at another side its declared input and output dimensions are
rewritten (its resizes follow the input's shape), as the page does (www/src/worker/segmenter/
side.js); that needs `pip install onnx`. Needs `pip install onnxruntime numpy` (in a venv).
One thread, like the CLI."""
import sys

import numpy as np
import onnxruntime as ort

MODEL = sys.argv[1]
opts = ort.SessionOptions()
opts.intra_op_num_threads = 1
opts.inter_op_num_threads = 1
sessions = {}


def session(side):
    if side not in sessions:
        model = MODEL
        if side != 320:
            import onnx

            m = onnx.load(MODEL)
            for t in list(m.graph.input) + list(m.graph.output):
                dims = t.type.tensor_type.shape.dim
                dims[2].dim_value = side
                dims[3].dim_value = side
            model = m.SerializeToString()
        sessions[side] = ort.InferenceSession(model, opts, providers=["CPUExecutionProvider"])
    return sessions[side]


stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
while True:
    head = stdin.read(4)
    if len(head) < 4:
        break
    side = int.from_bytes(head, "little")
    n = 3 * side * side * 4
    buf = stdin.read(n)
    if len(buf) < n:
        break
    sess = session(side)
    x = np.frombuffer(buf, dtype="<f4").reshape(1, 3, side, side)
    y = sess.run(None, {sess.get_inputs()[0].name: x})[0]
    stdout.write(np.ascontiguousarray(y, dtype="<f4").reshape(-1).tobytes())
    stdout.flush()
