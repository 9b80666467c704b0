"""Hardware behind small protocols (Arm, Gripper, Camera, Clock), the safety layer and cells."""

from fvfiles.user_cache import use_user_cache_for_numba

use_user_cache_for_numba()  # before a module of this package imports numba (see fvfiles/user_cache.py)
