// Footprint baseline: start-up code and an empty main, nothing of the core.
// See core_only.cpp.
volatile float g_out;

extern "C" void SysTick_Handler() {}

int main() {
  g_out = 1.0f;
  return 0;
}
