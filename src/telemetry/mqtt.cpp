#include "telemetry/mqtt.hpp"
