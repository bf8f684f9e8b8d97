"""The dataset store, below the pipeline, the reports, the scenes and the diff: files written
atomically (atomic), data files read only when they are regular files (regular), NetCDF
datasets written and read one way (netcdf) in the CF-1.10 conventions (cf). It imports
nothing else of creatio but its errors, so every layer that reads or writes results can use
it without importing another layer."""
