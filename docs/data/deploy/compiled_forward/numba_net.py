"""Study (2026-11-29, not shipped): the shipped crowd network's forward pass written out in numba (float32, in the ONNX
graph's order, weights read with the onnx package), against onnxruntime: the largest difference on 2 000 random rows
and the warm call times. Run: python numba_net.py. Result: 16 us against 19 us (docs/results.md)."""
import time, numpy as np, onnx
from onnx import numpy_helper
from numba import njit
from nn_export.runtime.policy import shipped_crowd_model_path

def weights(path):
    m = onnx.load(str(path))
    W = {i.name: numpy_helper.to_array(i) for i in m.graph.initializer}
    consts = {n.output[0]: numpy_helper.to_array(n.attribute[0].t) for n in m.graph.node if n.op_type == "Constant"}
    sel = consts["/Constant_output_0"].astype(np.float32)  # (180, 2): the previous wheel speeds
    f = np.float32
    return (W["net.x_mean"].astype(f), W["net.x_scale"].astype(f), W["onnx::MatMul_118"].astype(f), W["net.enc_slot.bias"].astype(f),
            W["onnx::MatMul_123"].astype(f), W["onnx::MatMul_124"].astype(f), W["net.enc_out.bias"].astype(f),
            np.ascontiguousarray(W["net.hidden.weight"].astype(f)), W["net.hidden.bias"].astype(f),
            np.ascontiguousarray(W["net.deeper.0.weight"].astype(f)), W["net.deeper.0.bias"].astype(f),
            np.ascontiguousarray(W["net.out.weight"].astype(f)), W["net.out.bias"].astype(f),
            W["net.y_scale"].astype(f), W["net.y_mean"].astype(f), W["onnx::MatMul_129"].astype(f), sel)

@njit(cache=False, fastmath=False)
def forward(x, mean, scale, W118, b_slot, W123, W124, b_out, Wh, bh, Wd, bd, Wo, bo, ysc, ymu, W129, sel, out):
    z = np.empty(180, np.float32)
    for i in range(180):
        z[i] = (x[i] - mean[i]) / scale[i]
    ww = np.zeros(32, np.float32)
    for k in range(32):
        ww[k] = z[0] * W123[0, k] + z[1] * W123[1, k]
    mx = np.full(32, -np.inf, np.float32)
    sm = np.zeros(32, np.float32)
    h = np.empty(32, np.float32)
    for s in range(18):
        base = 2 + 9 * s
        pres = z[base]
        for k in range(32):
            acc = np.float32(0.0)
            for i in range(8):
                acc += z[base + 1 + i] * W118[i, k]
            v = (b_slot[k] + acc) + ww[k]
            h[k] = v if v > 0 else np.float32(0.0)
        for k in range(32):
            acc = np.float32(0.0)
            for i in range(32):
                acc += h[i] * W124[i, k]
            v = b_out[k] + acc
            v = (v if v > 0 else np.float32(0.0)) * pres
            if v > mx[k]:
                mx[k] = v
            sm[k] += v
    c = np.empty(82, np.float32)
    c[0], c[1] = z[0], z[1]
    for i in range(16):
        c[2 + i] = z[164 + i]
    for k in range(32):
        c[18 + k] = mx[k]
        c[50 + k] = sm[k]
    h1 = np.empty(64, np.float32)
    for j in range(64):
        acc = np.float32(0.0)
        for i in range(82):
            acc += Wh[j, i] * c[i]
        h1[j] = np.tanh(acc + bh[j])
    h2 = np.empty(64, np.float32)
    for j in range(64):
        acc = np.float32(0.0)
        for i in range(64):
            acc += Wd[j, i] * h1[i]
        h2[j] = np.tanh(acc + bd[j])
    o = np.empty(2, np.float32)
    for j in range(2):
        acc = np.float32(0.0)
        for i in range(64):
            acc += Wo[j, i] * h2[i]
        o[j] = (acc + bo[j]) * ysc[j] + ymu[j]
    for j in range(2):
        acc = o[0] * W129[0, j] + o[1] * W129[1, j]
        prev = np.float32(0.0)
        for i in range(180):
            prev += x[i] * sel[i, j]
        v = acc + prev
        out[j] = min(max(v, np.float32(-0.7999999523162842)), np.float32(0.7999999523162842))

if __name__ == "__main__":
    import onnxruntime as ort
    path = shipped_crowd_model_path("improved")
    Ws = weights(path)
    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(1)
    X = rng.normal(0, 1, (2000, 180)).astype(np.float32) * rng.choice([0.1, 1, 5], (2000, 180)).astype(np.float32)
    want = sess.run(None, {"features": X})[0]
    got = np.empty_like(want)
    out = np.empty(2, np.float32)
    for i in range(len(X)):
        forward(X[i], *Ws, out)
        got[i] = out
    print("max |compiled - onnxruntime|:", np.abs(got - want).max(), "m/s")
    from nn_export.runtime.policy import OnnxPolicy
    net = OnnxPolicy(preset="improved")._crowd
    vals = X[0].astype(float).tolist()
    xbuf = np.empty(180, np.float32)
    def compiled(values):
        xbuf[:] = values
        forward(xbuf, *Ws, out)
        return float(out[0]), float(out[1])
    for name, fn in (("onnxruntime (policy's bound call)", net.answer), ("compiled", compiled)):
        ts = []
        for _ in range(3000):
            t = time.perf_counter(); fn(vals); ts.append(time.perf_counter() - t)
        print(f"{name}: median {np.median(ts)*1e6:.1f} us, p10 {np.percentile(ts, 10)*1e6:.1f} us")
