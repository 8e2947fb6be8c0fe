// SPDX-License-Identifier: MIT
// tools/imucal/cli.cpp: the subcommands and the help text.
#include "cli.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <new>

namespace imucal::cli {

namespace {

const char* const kHelp =
    R"(imucal: calibrate an IMU's accelerometer and gyroscope from a hand-turned recording
(still poses joined by turns), with the streaming calibrator that runs on the device; with
mx, my, mz columns also the magnetometer (hard and soft iron), with a temp column also the
biases' temperature dependence.

  imucal calibrate [options] FILE            imucal CSV (or - for stdin)
  imucal calibrate [options] ACC_FILE GYRO_FILE   imu_tk's two `t x y z` files
  imucal report -o PAGE.svg [options] FILE...     the same, plus a picture page
  imucal simulate -o FILE [--truth FILE] [--seed N] [--poses N] [--rate HZ]
                  [--initial-rest S] [--units counts|si]   a recording with known truth
  imucal record FILE                         print a calibration record (calibrate --record);
                                             exit 1 if it is not valid (what, at which byte)
  imucal noise [options] FILE                the noise of a STILL recording (the whole file):
                                             Allan deviation, white noise N, random walk K,
                                             bias instability B, quantisation Q per axis
  imucal field [options] FILE...             a recording of any length through the field
                                             calibrator (the gyro bias kept right in use):
                                             its published bias, rests and timeline

Input: imucal CSV has a header line naming its columns: t, ax, ay, az, gx, gy, gz (optional
temp, mx, my, mz; any order). The optional fields may be empty or NaN where the sensor gave no
reading (a magnetometer slower than the IMU). Lines starting with # are comments;
`# imucal: key=value ...` in a comment sets the data options below (the command line wins).
Each sensor may come alone, and each calibrates what it holds (exit 0 when that is usable):
  t, mx, my, mz (or no t)   the magnetometer alone (hard and soft iron)
  t, ax, ay, az             an accelerometer stream alone (rests found from it alone)
  ax, ay, az and no time    one pose mean per line (no t and no --rate, or --poses): the
                            accelerometer solved from the poses directly, equal weights
A file without a header: --columns names its columns; six numeric columns without it are
taken as ax ay az gx gy gz (three, with --poses, as ax ay az). Without a t column, --rate
gives sample i the time i/rate (needed with a gyroscope).

Options (calibrate, report):
  --format auto|csv|imutk         auto: two files are imu_tk, one is CSV
  --time-unit s|ms|us             unit of t (default s)
  --accel-unit counts|g|mps2      raw accelerometer unit (default mps2)
  --gyro-unit counts|dps|rads     raw gyroscope unit (default rads)
  --accel-lsb-per-g N             nominal counts per g, 1 .. 1e8 (counts: gives the "before"
                                  residual)
  --accel-zero Z                  nominal raw reading at 0 g (e.g. 32768; default 0), within
                                  -2147483648 .. 2147483647
  --gyro-lsb-per-dps N            nominal counts per deg/s, 0.01 .. 1e7 (counts: else the scale
                                  is searched)
  --gravity G                     local gravity, m/s^2, 9.7 .. 9.9 (default 9.80665)
  --initial-rest S                the shortest still period that starts the run: the first one found
                                  gives the starting gyro bias and noise (0.1 .. 3600, default 2)
  --min-rest S                    shorter still spells are not poses (0.05 .. 600, default 0.6)
  --accel-range LO,HI             the accelerometer's full scale, raw units (e.g. 0,65535): a
                                  reading at or beyond it is saturated (counted, taken as motion).
                                  In counts without it: readings all integers in -32768..32767
                                  are int16 and those in 0..65535 uint16, and a reading at the
                                  format's limits is saturated (the summary says so)
  --gyro-range LO,HI              the gyroscope's (a saturated sample is counted and refused;
                                  inferred in counts as for the accelerometer)
  --rate HZ                       the configured sample rate, 0.1 .. 100000: with a t column,
                                  seconds far from it are counted; without one, sample i is at
                                  i/HZ s
  --columns NAMES                 the columns of a file, in order, comma-separated: t, ax, ay,
                                  az, gx, gy, gz (or wx, wy, wz), temp, mx, my, mz; - or _ skips
                                  one (e.g. --columns ax,ay,az,gx,gy,gz); wins over a header line
                                  (then skipped)
  --poses                         the file holds one pose mean per line (ax ay az): the
                                  accelerometer alone, solved from the poses
  --refine-gyro-bias              estimate the gyro bias with the rest (12 parameters)
  --double                        run the double-precision reference instead of float
  --memory MB                     the memory the samples are kept in between passes (4 ..
                                  1048576, default 256): beyond it a file is read again, and
                                  stdin keeps every k-th sample (the summary says which)
  A number outside its range above is bad usage (exit 2), from the command line or a file.

Magnetometer (mx, my, mz; m_cal = S (m_raw + h), h added, S in uT per raw unit):
  --mag-unit counts|ut|nt|gauss   raw magnetometer unit (default ut)
  --mag-lsb-per-ut N              nominal counts per uT, 0.01 .. 1e6: required with counts (the
                                  field bounds and S are in uT)
  --mag-field-range LO,HI         accepted local field strength, uT (default 20,70)
  --mag-min-coverage F            fraction of the directions that must hold a sample (default 0.5)
  --no-mag-align                  keep S symmetric: no rotation into the accelerometer frame
                                  (default: aligned from the poses, constant dip)
  A failed magnetometer fit is reported (why) and does not change the exit code.

Temperature (temp, deg C; b(T) = b0 + b1 (T - T0) + b2 (T - T0)^2 replaces the added bias):
  --temp-order 1|2                linear or quadratic in T (default 1)
  --temp-min-span DEGC            the poses' temperatures must span this much (0.1 .. 200,
                                  default 5)
  Fitted from the poses' mean readings and temperatures, about the calibration; T0 is the
  recording's mean temperature. The accelerometer part needs poses in varied orientations.

Outputs:
  --json FILE                     every parameter and sigma, model, poses, configuration
  --header FILE                   a C/C++ header of constants for firmware (with IMUCAL_MAG_S,
                                  IMUCAL_MAG_H, IMUCAL_*_B_T for the usable mag/temperature parts)
  --record FILE                   the binary calibration record the firmware stores in flash
                                  (imucal/store/record.hpp: little-endian floats, CRC-32; with the
                                  magnetometer and temperature model when usable)
  --device-id N, --sensor-id N    the record's ids (unsigned 32-bit, decimal or 0x hex; default 0)
  --truth FILE                    compare with the truth file of `imucal simulate`
  --svg FILE, -o FILE             the SVG report page (report needs it; calibrate may write it)
  --quiet                         no progress display on the terminal

Noise (imucal noise; the input, unit and --columns/--rate options as for calibrate; counts
are reported as counts unless --gyro-lsb-per-dps / --accel-lsb-per-g give the scale):
  --json FILE                     the Allan deviation (68 % intervals, edf) and the fitted terms
  --kalibr FILE                   Kalibr's imu.yaml noise keys (SI units; per sensor the largest
                                  axis; a random walk not seen is given as the data's upper bound)
  --svg FILE                      a log-log plot: the deviation with its intervals, the fitted
                                  terms' asymptotes and the model

Field (imucal field; the input, unit, range, --rate, --initial-rest, --memory, --json and
--quiet options as for calibrate; the gyro's scale is needed: --gyro-lsb-per-dps in counts):
  --prior RECORD                  start from a calibration record (calibrate --record): its gyro
                                  bias and sigma, its temperature model; default: bias 0 +- 3 deg/s
  --gyro-noise RAD_S              the gyro's noise per sample and axis (1e-9 .. 1 rad/s) and the
  --accel-noise MPS2              accelerometer's (1e-9 .. 10 m/s^2); default: measured over the
                                  recording's initial rest, as calibrate does
  --gyro-zero Z                   the gyro's nominal raw reading at zero rate (e.g. 32768 for
                                  unsigned counts; default 0): the prior's bias is -Z
  --rest-piece S                  the longest piece a rest is judged in (1 .. 600, default 5): a
                                  bias is published only from a rest of more than one piece
  --at-temperature DEGC           the published bias also at this temperature (-60 .. 150)
  --json FILE                     the counts, the published bias and model, every event
  --svg FILE                      the picture page: each sensor's published bias over the
                                  recording with its decisions marked, and the temperature
  The summary: the rests found, taken and refused (why), changes and updates, the published
  bias with its sigma and temperature model, the accelerometer's bias and the magnetometer's
  hard iron (with a magnetometer in known units: --mag-unit, --mag-lsb-per-ut for counts; a
  --prior record's magnetometer part is its prior), and the timeline of events (the first 30
  and the last 10 of a longer one). Exit code 0 when a bias was published, 1 when none was.

The summary lists every rest found (each a pose), explains its counts, and, when the
calibration is refused or weak, says why and what to do next.
The header and the record are written only for a usable calibration, with the parts present.
Exit code: 0 a usable calibration of what the input holds (accelerometer and gyroscope; the
accelerometer or the magnetometer alone), 1 none (the summary says why), 2 bad usage or input.
`imucal record`: 0 a valid record, 1 not valid, 2 bad usage or an unreadable file.
)";

// The command's exit code, or 2 (the reason on stderr) if what it printed did not all reach
// stdout: a full disk or device, a pipe's reader gone with an error.
int stdout_written(int code) {
  errno = 0;
  if (std::fflush(stdout) == 0 && std::ferror(stdout) == 0) return code;
  const int error = errno;
  std::fprintf(stderr, "imucal: cannot write to stdout: %s\n",
               error != 0 ? std::strerror(error) : "an earlier write failed");
  return 2;
}

}  // namespace

int imucal_main(const std::vector<std::string>& args) {
  if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
    std::fputs(kHelp, args.empty() ? stderr : stdout);
    return stdout_written(args.empty() ? 2 : 0);
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  try {
    if (args[0] == "calibrate") return stdout_written(calibrate_command(rest, false));
    if (args[0] == "report") return stdout_written(calibrate_command(rest, true));
    if (args[0] == "simulate") return stdout_written(simulate_command(rest));
    if (args[0] == "record") return stdout_written(record_command(rest));
    if (args[0] == "noise") return stdout_written(noise_command(rest));
    if (args[0] == "field") return stdout_written(field_command(rest));
  } catch (const std::bad_alloc&) {
    // calibrate and report keep up to --memory MB of samples between passes.
    std::fprintf(stderr,
                 "imucal %s: out of memory: give a smaller --memory (the samples kept between "
                 "passes; default 256 MB), or run it where there is more memory\n",
                 args[0].c_str());
    return 2;
  }
  std::fprintf(
      stderr,
      "imucal: unknown command '%s' (calibrate, report, simulate, record, noise, field, help)\n",
      args[0].c_str());
  return 2;
}

}  // namespace imucal::cli
