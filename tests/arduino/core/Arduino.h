// SPDX-License-Identifier: MIT
// A stand-in for an Arduino core's Arduino.h (tools/arduino/build_sketch.sh): what the example
// sketch calls (Serial, delay, random) over semihosting, and the core's macros that clash with
// C++ code (abs, constrain, sq, bit, PI, DEFAULT, CHANGE, B0, B1 ...), so that a sketch or an
// imucal source that trips over one fails here as on a board.
#pragma once

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif
void delay(unsigned long ms);
unsigned long millis(void);
#ifdef __cplusplus
}
#endif

#define HIGH 0x1
#define LOW 0x0
#define INPUT 0x0
#define OUTPUT 0x1
#define CHANGE 2
#define FALLING 3
#define RISING 4
#define DEFAULT 1
#define PI 3.1415926535897932384626433832795
#define HALF_PI 1.5707963267948966192313216916398
#define TWO_PI 6.283185307179586476925286766559
#define DEG_TO_RAD 0.017453292519943295769236907684886
#define RAD_TO_DEG 57.295779513082320876798154814105
#define EULER 2.718281828459045235360287471352
#define SERIAL 0x0
#define DISPLAY 0x1
#define LSBFIRST 0
#define MSBFIRST 1
#define B0 0
#define B1 1
#define B10 2
#define B11 3
#define abs(x) ((x) > 0 ? (x) : -(x))
#define constrain(amt, low, high) ((amt) < (low) ? (low) : ((amt) > (high) ? (high) : (amt)))
#define radians(deg) ((deg)*DEG_TO_RAD)
#define degrees(rad) ((rad)*RAD_TO_DEG)
#define sq(x) ((x) * (x))
#define lowByte(w) ((uint8_t)((w)&0xff))
#define highByte(w) ((uint8_t)((w) >> 8))
#define bit(b) (1UL << (b))

#ifdef __cplusplus
template <class T, class L>
auto min(const T& a, const L& b) -> decltype((b < a) ? b : a) {
  return (b < a) ? b : a;
}
template <class T, class L>
auto max(const T& a, const L& b) -> decltype((b < a) ? b : a) {
  return (a < b) ? b : a;
}

long random(long howbig);
long random(long howsmall, long howbig);

class SerialStub {
 public:
  void begin(unsigned long baud);
  size_t print(const char* s);
  size_t print(char c);
  size_t print(int n);
  size_t print(unsigned n);
  size_t print(long n);
  size_t print(unsigned long n);
  size_t print(double x, int digits = 2);
  size_t println(const char* s);
  size_t println(int n);
  size_t println(double x, int digits = 2);
  size_t println();
};
extern SerialStub Serial;

void setup();
void loop();
#endif
