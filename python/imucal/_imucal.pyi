# SPDX-License-Identifier: MIT
# The compiled part of the imucal package (python/imucal_module.cpp); the package's tests hold
# these signatures equal to the module's own.
from typing import Any, Dict, List, Optional, Tuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

__version__: str
ACCEL_PARAMETERS: Tuple[str, ...]
GYRO_PARAMETERS: Tuple[str, ...]

def calibrate(acc: Optional[ArrayLike], gyro: Optional[ArrayLike], t: Optional[ArrayLike],
              mag: Optional[ArrayLike], temp: Optional[ArrayLike],
              args: List[str]) -> Tuple[str, str, Optional[bytes], bool]: ...
def field(acc: Optional[ArrayLike], gyro: Optional[ArrayLike], t: Optional[ArrayLike],
          mag: Optional[ArrayLike], temp: Optional[ArrayLike], prior: Optional[bytes],
          args: List[str]) -> Tuple[str, str, bool]: ...
def noise(acc: Optional[ArrayLike], gyro: Optional[ArrayLike], t: Optional[ArrayLike],
          args: List[str]) -> Tuple[str, str, Optional[str]]: ...
def decode_record(record: bytes) -> Dict[str, Any]: ...

class Corrector:
    def __init__(self, record: bytes) -> None: ...
    def apply(self, acc: ArrayLike, gyro: ArrayLike, temp: Optional[ArrayLike] = None
              ) -> Tuple[NDArray[np.float64], NDArray[np.float64]]: ...
