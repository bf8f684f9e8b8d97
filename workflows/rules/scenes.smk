# Scenes: the notebook's viewers as products (creatio.scenes), planned from what they draw.
#
#   snakemake scenes -c 2                                       data/scenes/<scene>/
#   snakemake scenes -c 2 --config 'overrides=["sphere.mu=0.3"]'  -> data/runs/<hash>/scenes/
#   snakemake scenes -c 2 --config 'scenes=["en02"]'            a subset of the scenes
#
# Each scene writes scene.nc (exactly what it draws, with provenance), index.html (one offline
# file), animation.webp and poster.png. Its frames job computes the scene's own frames
# (frames.nc, temporary: what the animation draws), reading a study dataset of the same
# resolved config when one exists (its extra input). An explorable scene (scene.axes) also
# has a family: batch jobs compute its members (each kept in data/scenes/members/ and reused
# by key) while the frames job and the animation run, and its dataset job gathers them.
from creatio.scenes.assets import library_inputs
from creatio.scenes.plan import SceneRuns, scene_ids

SCENES = SceneRuns(config.get("overrides"), config.get("scenes"))
# A scene that reads a study's dataset (en04) names the study config whose rules build it.
JOBS.fallbacks.insert(0, lambda: SCENES.study_jobs(JOBS))
SCENE_LIBRARY = "data/scenes/lib/three.min.js"


localrules:
    scenes,
    scene_config,
    scene_library,
    scene_page,


rule scenes:
    input:
        lambda wc: SCENES.targets(),


# No params: the library exists in every invocation after the first, and checking a job's
# params makes Snakemake's process import pandas while it builds the DAG (0.15 s of every
# `snakemake scenes`); its command is the workflow's CREATIO, its inputs what it bundles.
rule scene_library:
    input:
        [str(p) for p in library_inputs()],
    output:
        SCENE_LIBRARY,
    conda:
        "../envs/scene-library.yaml"
    log:
        "data/logs/scenes/library.log",
    shell:
        f"{CREATIO} task scene library {{output}} 2> {{log}}"


rule scene_config:
    output:
        "{root}/scenes/{scene}/config.yaml",
    wildcard_constraints:
        scene=scene_ids(),
    params:
        config_sha256=lambda wc: SCENES.sha(wc.root, wc.scene),
    log:
        "{root}/logs/scenes/{scene}_config.log",
    run:
        with PLAN.lock:
            SCENES.write(wildcards.root, wildcards.scene, output[0], log[0])


rule scene_family_batch:
    input:
        config="{root}/scenes/{scene}/config.yaml",
    output:
        "{root}/scenes/{scene}/family/b{size}-{batch}.nc",
    wildcard_constraints:
        scene=scene_ids(),
        size=r"\d+",
        batch=r"\d{5}",
    params:
        creatio=CREATIO,
        code=code_version("datasets") + code_version("scenes"),
        store=SCENES.store,
    threads: 1
    conda:
        "../envs/creatio.yaml"
    benchmark:
        "{root}/logs/scenes/{scene}_family_b{size}-{batch}.tsv"
    log:
        "{root}/logs/scenes/{scene}_family_b{size}-{batch}.log",
    shell:
        "{params.creatio} task scene family-batch {wildcards.scene} {output} "
        "--config-file {input.config} --batch {wildcards.batch} --batch-size {wildcards.size} "
        "--store {params.store} 2> {log}"


rule scene_frames:
    input:
        lambda wc: list(SCENES.reuse(wc.root, wc.scene).values()),
        config="{root}/scenes/{scene}/config.yaml",
    output:
        temp("{root}/scenes/{scene}/frames.nc"),
    wildcard_constraints:
        scene=scene_ids(),
    priority: 1  # first: the animation, the longest job, waits for it
    params:
        creatio=CREATIO,
        code=code_version("datasets") + code_version("scenes"),
        reuse=lambda wc: SCENES.reuse_args(wc.root, wc.scene),
    conda:
        "../envs/creatio.yaml"
    benchmark:
        "{root}/logs/scenes/{scene}_frames.tsv"
    log:
        "{root}/logs/scenes/{scene}_frames.log",
    shell:
        "{params.creatio} task scene frames {wildcards.scene} {output} "
        "--config-file {input.config} {params.reuse} 2> {log}"


rule scene_dataset:
    input:
        frames="{root}/scenes/{scene}/frames.nc",
        config="{root}/scenes/{scene}/config.yaml",
        family=lambda wc: SCENES.family(wc.root, wc.scene),
    output:
        "{root}/scenes/{scene}/scene.nc",
    wildcard_constraints:
        scene=scene_ids(),
    params:
        creatio=CREATIO,
        code=code_version("datasets") + code_version("scenes"),
        store=SCENES.store,
    conda:
        "../envs/creatio.yaml"
    benchmark:
        "{root}/logs/scenes/{scene}_dataset.tsv"
    log:
        "{root}/logs/scenes/{scene}_dataset.log",
    shell:
        "{params.creatio} task scene dataset {wildcards.scene} {output} "
        "--config-file {input.config} --frames {input.frames} --family {input.family} "
        "--store {params.store} 2> {log}"


rule scene_page:
    input:
        nc="{root}/scenes/{scene}/scene.nc",
        library=SCENE_LIBRARY,
    output:
        "{root}/scenes/{scene}/index.html",
    wildcard_constraints:
        scene=scene_ids(),
    params:
        creatio=CREATIO,
        code=code_version("scenes"),
    conda:
        "../envs/creatio.yaml"
    benchmark:
        "{root}/logs/scenes/{scene}_page.tsv"
    log:
        "{root}/logs/scenes/{scene}_page.log",
    shell:
        "{params.creatio} task scene page {input.nc} {input.library} {output} 2> {log}"


rule scene_media:
    input:
        "{root}/scenes/{scene}/frames.nc",
    output:
        animation="{root}/scenes/{scene}/animation.webp",
        poster=reported_scene("{root}/scenes/{scene}/poster.png"),
    wildcard_constraints:
        scene=scene_ids(),
    params:
        creatio=CREATIO,
        code=code_version("scenes"),
    conda:
        "../envs/creatio.yaml"
    benchmark:
        "{root}/logs/scenes/{scene}_media.tsv"
    log:
        "{root}/logs/scenes/{scene}_media.log",
    shell:
        "{params.creatio} task scene media {input} {output.animation} {output.poster} "
        "2> {log}"
