import sys, time, numpy as np
sys.argv = ["x", "files:out/held2/replay/students001/*.toml", "2"]
src = open(__file__.replace("fatrop_loop.py", "fatrop_opts.py")).read().split("F.FatropBackend._solve = orig\n")[0]
exec(src)
F.FatropBackend._solve = orig
backs = {}
t0 = time.time(); n = 0
print("recorded", len(recorded), flush=True)
open("/tmp/fatrop_ready", "w").write("1")
while time.time() - t0 < 12:
    for prob, p, u0 in recorded:
        b = backs.get(id(prob))
        if b is None:
            b = backs[id(prob)] = F.FatropBackend("fatrop", prob, True)
        b._solve(p, u0, None, None); n += 1
print("solves", n)
