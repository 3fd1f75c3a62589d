// Result<T> and Status moved to the core/ room (dentar/core/result.h); this
// name stays for the modules above volume/ that include it.
#pragma once

#include "dentar/core/result.h"
