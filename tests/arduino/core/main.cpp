// SPDX-License-Identifier: MIT
// The stand-in core's main() and Serial (tools/arduino/build_sketch.sh): setup(), then loop() a
// few times, output through semihosting (QEMU prints it); time runs only in delay().
#include <stdio.h>

#include "Arduino.h"

SerialStub Serial;

namespace {
unsigned long now_ms = 0;
unsigned long seed = 12345u;
}  // namespace

extern "C" void delay(unsigned long ms) { now_ms += ms; }
extern "C" unsigned long millis(void) { return now_ms; }

long random(long howbig) {
  seed = seed * 1103515245u + 12345u;
  return howbig <= 0 ? 0 : static_cast<long>((seed >> 8) % static_cast<unsigned long>(howbig));
}
long random(long howsmall, long howbig) {
  return howsmall >= howbig ? howsmall : howsmall + random(howbig - howsmall);
}

void SerialStub::begin(unsigned long) {}
size_t SerialStub::print(const char* s) { return static_cast<size_t>(printf("%s", s)); }
size_t SerialStub::print(char c) { return static_cast<size_t>(printf("%c", c)); }
size_t SerialStub::print(int n) { return static_cast<size_t>(printf("%d", n)); }
size_t SerialStub::print(unsigned n) { return static_cast<size_t>(printf("%u", n)); }
size_t SerialStub::print(long n) { return static_cast<size_t>(printf("%ld", n)); }
size_t SerialStub::print(unsigned long n) { return static_cast<size_t>(printf("%lu", n)); }
size_t SerialStub::print(double x, int digits) {
  return static_cast<size_t>(printf("%.*f", digits, x));
}
size_t SerialStub::println(const char* s) { return static_cast<size_t>(printf("%s\n", s)); }
size_t SerialStub::println(int n) { return static_cast<size_t>(printf("%d\n", n)); }
size_t SerialStub::println(double x, int digits) {
  return static_cast<size_t>(printf("%.*f\n", digits, x));
}
size_t SerialStub::println() { return static_cast<size_t>(printf("\n")); }

int main() {
  setup();
  for (int i = 0; i < 3; ++i) loop();
  return 0;
}
