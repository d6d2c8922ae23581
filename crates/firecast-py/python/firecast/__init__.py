"""FireCast's helitack environment for Gymnasium and Stable-Baselines3.

The simulator is FireCast's Rust crate ``firecast-sim`` (extension module
``firecast._firecast``); this package adds the Python interfaces:

- :class:`HelitackEnv`, a ``gymnasium.Env`` (registered as ``firecast/Helitack-v0``);
- :class:`HelitackVecEnv`, a Stable-Baselines3 ``VecEnv`` over the Rust ``VecEnv``, and
  :class:`CompactExtractor`, FireCast's compact CNN as an SB3 features extractor (both
  imported on first use, so ``import firecast`` does not import SB3 or torch);
- ``ACTIONS``: the action names by number (0 north, up on the north-up render).

Example::

    import gymnasium, firecast
    env = gymnasium.make("firecast/Helitack-v0", landscape={"procedural": {"seed": 3}})
    obs, info = env.reset(seed=0)
"""

from __future__ import annotations

import gymnasium

from . import _firecast
from ._common import ACTIONS
from .env import HelitackEnv

__version__ = _firecast.__version__
PROFILES: tuple[str, ...] = tuple(_firecast.PROFILES)
ENV_ID = "firecast/Helitack-v0"

__all__ = ["ACTIONS", "ENV_ID", "PROFILES", "CompactExtractor", "HelitackEnv", "HelitackVecEnv", "__version__"]

if ENV_ID not in gymnasium.registry:
    # Episodes truncate inside the environment (config `max_steps`), so no TimeLimit wrapper.
    gymnasium.register(id=ENV_ID, entry_point="firecast.env:HelitackEnv", nondeterministic=False)


def __getattr__(name: str):
    if name == "HelitackVecEnv":
        from .vec_env import HelitackVecEnv

        return HelitackVecEnv
    if name == "CompactExtractor":
        from .extractor import CompactExtractor

        return CompactExtractor
    raise AttributeError(f"module 'firecast' has no attribute {name!r}")
