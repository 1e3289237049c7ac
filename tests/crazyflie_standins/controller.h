/* Minimal stand-in for the Crazyflie firmware's src/modules/interface/controller/controller.h (bitcraze/crazyflie-firmware,
   commit 2a18fc299d7b48cf094d26c38a79f33dec64b5d7): the out-of-tree controller's prototypes, as declared there under
   CONFIG_CONTROLLER_OOT. */
#ifndef __CONTROLLER_H__
#define __CONTROLLER_H__

#include "stabilizer_types.h"

void controllerOutOfTreeInit(void);
bool controllerOutOfTreeTest(void);
void controllerOutOfTree(control_t *control, const setpoint_t *setpoint, const sensorData_t *sensors, const state_t *state, const stabilizerStep_t stabilizerStep);

#endif
