# SPDX-License-Identifier: MIT
# The library's parts and their sources, read by every build that compiles imucal: the CMake
# project (CMakeLists.txt), the ESP-IDF component (the same file under ESP_PLATFORM) and the
# Zephyr module (zephyr/CMakeLists.txt). Paths are relative to imucal's root.
#   core          status, record codec, corrector (load and apply)
#   calibrator    accelerometer and gyroscope solvers, the streaming calibrator
#   magnetometer  magnetometer collector, solve and alignment
#   temperature   bias against temperature: rest monitor and fit
#   store         the two-slot record store over a flash port
set(IMUCAL_PART_SOURCES_core lib/status.cpp lib/record.cpp)
set(IMUCAL_PART_SOURCES_calibrator lib/accel_calibration.cpp lib/gyro_calibration.cpp)
set(IMUCAL_PART_SOURCES_magnetometer lib/mag_calibration.cpp)
set(IMUCAL_PART_SOURCES_temperature lib/temperature_fit.cpp)
set(IMUCAL_PART_SOURCES_store lib/record_store.cpp)
set(IMUCAL_PART_DEPENDS_calibrator core)
set(IMUCAL_PART_DEPENDS_magnetometer calibrator)
set(IMUCAL_PART_DEPENDS_temperature calibrator)
set(IMUCAL_PART_DEPENDS_store core)
# In dependency order: a part comes after every part it depends on.
set(IMUCAL_PARTS core calibrator magnetometer temperature store)
set(IMUCAL_SOURCES "")
foreach(part IN LISTS IMUCAL_PARTS)
  list(APPEND IMUCAL_SOURCES ${IMUCAL_PART_SOURCES_${part}})
endforeach()
# The include folders: the library's headers, and the flash port's simulated flashes.
set(IMUCAL_INCLUDE_DIRS include ports/include)
# Flags of imucal's own sources in every build, never of a consumer's: no dynamic Eigen
# allocation, and sqrtf as one instruction (the library checks its own inputs and never reads
# errno).
set(IMUCAL_PRIVATE_DEFINITIONS EIGEN_NO_MALLOC)
set(IMUCAL_PRIVATE_OPTIONS -fno-exceptions -fno-rtti -fno-math-errno)
