/* Minimal stand-in for the Crazyflie firmware's src/modules/interface/controller/attitude_controller.h
   (bitcraze/crazyflie-firmware, commit 2a18fc299d7b48cf094d26c38a79f33dec64b5d7): the prototypes the example calls. */
#ifndef ATTITUDE_CONTROLLER_H_
#define ATTITUDE_CONTROLLER_H_

#include <stdbool.h>
#include <stdint.h>

void attitudeControllerInit(const float updateDt);
bool attitudeControllerTest(void);
void attitudeControllerCorrectAttitudePID(
       float eulerRollActual, float eulerPitchActual, float eulerYawActual,
       float eulerRollDesired, float eulerPitchDesired, float eulerYawDesired,
       float* rollRateDesired, float* pitchRateDesired, float* yawRateDesired);
void attitudeControllerCorrectRatePID(
       float rollRateActual, float pitchRateActual, float yawRateActual,
       float rollRateDesired, float pitchRateDesired, float yawRateDesired);
void attitudeControllerGetActuatorOutput(int16_t* roll, int16_t* pitch, int16_t* yaw);

#endif
