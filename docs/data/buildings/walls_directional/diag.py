import sys, json
from casadi_gpc.config import preset
from scenarios.suites import Suite
from gpcnav.commands.simulate import run_one
from gpcnav.commands.common import for_run, with_settings
suite, idx = sys.argv[1], int(sys.argv[2])
sc = Suite(suite, 200, 13, 5, "orca").scenario(idx)
for label, sets in (("shipped", []), ("D", ["walls_directional_sigma=true"])):
    cfg = for_run(with_settings(preset("improved"), sets), [sc])
    doc = run_one(sc, "gpc", cfg)
    print(label, doc["outcome"], doc.get("collision"), "interventions", doc["interventions"])
    if label == "D":
        json.dump(doc, open(f"/tmp/aniso/{suite}{idx}-D.json", "w"))
