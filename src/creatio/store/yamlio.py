"""YAML text read the one safe way everywhere (a dataset's config, a job's config file)."""

from __future__ import annotations

from typing import Any

import yaml

__all__ = ["load_yaml"]

#: libyaml's safe loader where PyYAML was built with it: the same objects as
#: ``yaml.safe_load`` (the same resolver and constructor; only the scanner and parser are C)
#: about 8x faster, 0.4 ms instead of 3.5 ms for a study's config here.
_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def load_yaml(text: str) -> Any:
    """The Python objects of YAML text, as ``yaml.safe_load`` gives them."""
    return yaml.load(text, Loader=_LOADER)  # noqa: S506 - a safe loader, C or Python
