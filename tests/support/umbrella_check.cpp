// Compiled, never run: the umbrella header includes on its own, and a program needs nothing else.
#include <smoketrace/smoketrace.hpp>
