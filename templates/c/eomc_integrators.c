#include "eomc_integrators.h"
