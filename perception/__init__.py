"""FingerVision perception: camera frames in, one `TactileState` per finger per frame out."""

from fvfiles.user_cache import use_user_cache_for_numba

use_user_cache_for_numba()  # before a module of this package imports numba (see fvfiles/user_cache.py)

from perception.state import FINGERS, MarkerField, ObjectInfo, TactileState

__all__ = ["FINGERS", "MarkerField", "ObjectInfo", "TactileState"]
