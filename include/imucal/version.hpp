// SPDX-License-Identifier: MIT
// imucal/version.hpp: imucal's version, as in project(VERSION) and every ecosystem's manifest
// (ctest versions_agree holds them equal; CHANGELOG.md says what each version offers).
#pragma once

#define IMUCAL_VERSION_MAJOR 0
#define IMUCAL_VERSION_MINOR 1
#define IMUCAL_VERSION_PATCH 0
#define IMUCAL_VERSION_STRING "0.1.0"
