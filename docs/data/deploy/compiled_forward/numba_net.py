"""Study (2026-11-29): the shipped crowd network's forward pass compiled (numba, float32, in the ONNX graph's
order) against onnxruntime: the largest difference on 2 000 random rows and the warm call times. Run: python
numba_net.py. Result then: 16 us against 19 us (docs/results.md). The loop written here that day became the
product's nn_export.runtime.compiled_set (2026-11-30: any set network, its weights read from the file without the
onnx package, an option of OnnxPolicy), which this script now times in its place."""
import time
import numpy as np
import onnxruntime as ort
from nn_export import OnnxPolicy
from nn_export.runtime.compiled_set import compile_set_network
from nn_export.runtime.policy import shipped_crowd_model_path

if __name__ == "__main__":
    path = shipped_crowd_model_path("improved")
    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    net = OnnxPolicy(preset="improved")._crowd  # onnxruntime, the policy's bound call
    compiled, executor = compile_set_network(path.read_bytes(), net.layout.size, net.layout.set_slots,
                                             lambda X: sess.run(None, {"features": X})[0])
    print(executor)
    rng = np.random.default_rng(1)
    X = rng.normal(0, 1, (2000, 180)).astype(np.float32) * rng.choice([0.1, 1, 5], (2000, 180)).astype(np.float32)
    want = sess.run(None, {"features": X})[0]
    got = np.array([compiled.answer(x) for x in X])
    print("max |compiled - onnxruntime|:", np.abs(got - want).max(), "m/s")
    vals = X[0].astype(float).tolist()
    xbuf = np.empty(180, np.float32)

    def compiled_call(values):
        xbuf[:] = values
        return compiled.answer(xbuf)
    for name, fn in (("onnxruntime (policy's bound call)", net.answer), ("compiled", compiled_call)):
        ts = []
        for _ in range(3000):
            t = time.perf_counter(); fn(vals); ts.append(time.perf_counter() - t)
        print(f"{name}: median {np.median(ts)*1e6:.1f} us, p10 {np.percentile(ts, 10)*1e6:.1f} us")
