// SPDX-License-Identifier: MIT
// tools/imucal/report_svg_sections.hpp: the sections of the `imucal` tool's SVG report page,
// top to bottom, one file each (host only). Each draws from y down and returns the y below it.
#pragma once

#include <string>
#include <vector>

#include "report_svg_kit.hpp"

namespace imucal::cli::report {

// report_svg.cpp: the title, the verdict and the counts.
double title_block(Page& page, const Run& run, const Options& options);

// report_svg_signals.cpp: raw accelerometer or gyroscope, three axes over time (rests shaded);
// |a| before and after the calibration, the pose levels, gravity.
double signal_section(Page& page, double y, double h, const Run& run,
                      const std::vector<Sample>& samples, const TimeAxis& t, bool gyro,
                      const std::string& title, const std::string& unit, bool numbers,
                      bool time_title);
double norm_section(Page& page, double y, const Run& run, const Options& options,
                    const std::vector<Sample>& samples, const TimeAxis& t);

// report_svg_residuals.cpp: residuals per pose or per move, before and after, as bars; the
// pose directions on two hemispheres.
struct Bars {
  std::string title, unit, after_colour, empty_text, item_name;
  std::vector<double> before, after;
  std::vector<std::string> tips;
  double rms_before = kNaN, rms_after = kNaN;
};
double bar_section(Page& page, double y, const Bars& bars);
double sphere_section(Page& page, double y, const Run& run);

// report_svg_magnetometer.cpp: raw and calibrated readings in three projections.
double mag_section(Page& page, double y, const Run& run, const Options& options,
                   const std::vector<Sample>& samples);

// report_svg_temperature.cpp: the biases against temperature.
double temperature_section(Page& page, double y, const Run& run, const Options& options);

}  // namespace imucal::cli::report
