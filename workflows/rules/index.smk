# The entry point to everything built: data/index.html (static, offline), the page of
# `creatio ls` / `creatio open NAME` (creatio.pipeline.index). `all` asks for it; after every
# successful run (studies, a sweep, scenes, benchmarks, beyond) list_results (common.smk, the
# Snakefile's onsuccess) rewrites it when what it lists changed, and says where it is. The
# rule has no input on purpose: a set of inputs that follows the invocation's targets would
# rerun it on every change of --config.
from creatio.pipeline.index import write_index


localrules:
    index,


rule index:
    output:
        "data/index.html",
    log:
        "data/logs/index.log",
    priority: -10
    run:
        with PLAN.lock:
            page = write_index("data", output[0])
        Path(log[0]).write_text(f"wrote {page}\n")
