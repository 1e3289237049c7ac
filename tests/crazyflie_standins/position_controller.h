/* Minimal stand-in for the Crazyflie firmware's src/modules/interface/controller/position_controller.h
   (bitcraze/crazyflie-firmware, commit 2a18fc299d7b48cf094d26c38a79f33dec64b5d7): the prototypes the example calls. */
#ifndef POSITION_CONTROLLER_H_
#define POSITION_CONTROLLER_H_

#include "stabilizer_types.h"

void positionControllerInit(void);
void positionController(float* thrust, attitude_t *attitude, const setpoint_t *setpoint,
                                                             const state_t *state);

#endif
