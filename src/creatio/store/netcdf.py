"""NetCDF datasets written and read one way: compressed CF-1.10 NetCDF4 (creatio.store.cf),
atomically (creatio.store.atomic), and read back as their study made them."""

from __future__ import annotations

import errno
import json
import os
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.store import cf
from creatio.store.atomic import _create, _prepare, atomic_path, clean_stale
from creatio.store.regular import check_regular
from creatio.store.yamlio import load_yaml

__all__ = ["read_dataset", "write_dataset"]

SMALL_BYTES = 4096


def _no_space(path: Path, error: Exception) -> OSError:
    """The cause of a failed write where the library names none ("NetCDF: HDF error"): a
    full disk is named as such."""
    try:
        free = shutil.disk_usage(path.parent).free
    except OSError:
        free = -1
    if isinstance(error, OSError) and error.errno in (errno.ENOSPC, errno.EDQUOT):
        return OSError(error.errno, os.strerror(error.errno), str(path))
    if 0 <= free < 1 << 20:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    return OSError(errno.EIO, f"could not be written ({error})", str(path))


def _netcdf_attr(value: Any) -> Any:
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, Mapping | list | tuple) and not isinstance(value, str):
        return json.dumps(value)
    if value is None:
        return ""
    return value


def _encoding(ds: xr.Dataset) -> dict[Any, dict[str, Any]]:
    """Storage of each variable: CF's (text as character arrays, coordinates without
    _FillValue), and compression for what is large; small variables are stored
    contiguously (chunk indexes and compression headers would cost more than they save)."""
    encoding = cf.encoding(ds)
    for name, var in ds.variables.items():
        if var.dtype.kind not in "fiub" and not cf.is_string(var):
            continue
        if var.size == 0:  # HDF5 refuses contiguous storage of nothing (an empty event table)
            continue
        size = var.nbytes
        if cf.is_string(var):
            size = var.size * max((len(str(v).encode()) for v in np.ravel(var.values)),
                                  default=1)
        encoding[name].update({"zlib": True, "complevel": 4} if size > SMALL_BYTES
                              else {"contiguous": True})
    return encoding


def write_dataset(ds: xr.Dataset, path: str | Path) -> Path:
    """Write ds as compressed CF-1.10 NetCDF4 atomically (temp file, then rename); the
    metadata are made CF-conformant here, once for every dataset (creatio.store.cf)."""
    path = Path(path)
    _prepare(path)
    ds = ds.copy()
    ds.attrs = {k: _netcdf_attr(v) for k, v in ds.attrs.items()}
    for var in ds.variables.values():
        var.attrs = {k: _netcdf_attr(v) for k, v in var.attrs.items()}
    ds = cf.conform(ds)
    encoding = _encoding(ds)
    clean_stale(path)
    tmp = atomic_path(path)
    try:
        _create(tmp, path)  # a place that holds no file is named as such, not "HDF error"
        try:
            ds.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=encoding)
        except (OSError, RuntimeError) as e:  # netCDF4 reports a full disk as "HDF error"
            raise _no_space(path, e) from None
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def read_dataset(path: str | Path) -> tuple[xr.Dataset, dict]:
    """Load a dataset fully into memory and return it with its resolved config, as its
    study made it: the units it stated and text labels as strings (cf.restore)."""
    path = Path(path)
    try:
        check_regular(path)  # netCDF4 would block on a FIFO and read a device forever
    except FileNotFoundError:
        raise FileNotFoundError(errno.ENOENT, "no dataset here", str(path)) from None
    try:
        # Times stay seconds (CF's reference date is a placeholder: docs/datasets.md).
        ds = cf.restore(xr.load_dataset(path, engine="netcdf4", decode_times=False))
        config = load_yaml(ds.attrs.get("config_yaml", "")) or {}
    except Exception as e:  # noqa: BLE001 - truncated, not NetCDF, unreadable attrs
        raise OSError(errno.EIO, f"not a readable creatio dataset ({type(e).__name__}): "
                      "remove it and rerun the rule that makes it", str(path)) from None
    return ds, config
