"""`needs_fused_cabs`: skips a test that compares libm.cabs (a fused multiply-add) with numpy's
complex absolute bit for bit where numpy's loop rounds twice (its baseline, no FMA)."""

import numpy as np
import pytest

# A value where the fused and the twice-rounded complex absolute differ.
NUMPY_FUSES = float(np.abs(np.complex128(0.7813114007004275 - 0.1904494670360214j))) == (
    0.8041881025971279
)
needs_fused_cabs = pytest.mark.skipif(
    not NUMPY_FUSES, reason="numpy's complex absolute rounds twice here (no FMA); libm.cabs fuses"
)
