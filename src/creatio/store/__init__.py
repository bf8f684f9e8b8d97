"""The dataset store, below the pipeline, the reports, the scenes and the diff: files written
atomically (atomic), NetCDF datasets written and read one way (netcdf) in the CF-1.10
conventions (cf). It imports nothing else of creatio, so every layer that reads or writes
results can use it without importing another layer."""
