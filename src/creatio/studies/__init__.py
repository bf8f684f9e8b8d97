"""Studies: a validated config in, an ``xarray.Dataset`` out (docs/studies.md).

The registry (creatio.studies.registry) lists every study with its schema, run function and
report writer; creatio.studies.schema holds the config schemas. Provenance is added by the
pipeline, in one place (creatio.pipeline.run).
"""
