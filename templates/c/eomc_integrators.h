/* eomc_integrators.h: integrators over eomc_model (see eomc_model.h). */
#ifndef EOMC_INTEGRATORS_H
#define EOMC_INTEGRATORS_H
#include "eomc_model.h"
#endif
