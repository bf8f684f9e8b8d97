"""Scenes: the CREATIO notebook's viewers as first-class products of the pipeline.

A scene is a config (``conf/scene/<id>.yaml``) that says what it draws; :mod:`.plan` derives
what it must compute from that (frame times only, no energy, no dt / 2 partner, rotation only
when drawn) or finds a study dataset that already holds it; :mod:`.compute` makes
``scene.nc`` (with provenance, :mod:`.run`), :mod:`.page` the offline ``index.html`` and
:mod:`.media` the animation and poster. ``snakemake scenes`` builds them all
(workflows/rules/scenes.smk).
"""
