"""The Crazyflie out-of-tree controller example compiles against stand-ins for the firmware and flies the export.

The stand-in headers (tests/crazyflie_standins/) are written from the firmware's public
definitions (each cites its file and commit).  A stub firmware records what the example
asks of the attitude loop; the setpoints are compared with the numpy controller fed the
frame conversion done by hand here, and their signs with the firmware's own position PID
convention (``pitch = -PID(vx)``, ``roll = -PID(vy)`` in ``position_controller_pid.c``).
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from nniquad.certificates.certificate import read_certificate
from nniquad.certificates.export import controller_from_certificate, export_prefix

CERT = Path(__file__).resolve().parents[1] / "notebooks" / "data" / "full_model_certificate.json"
STANDINS = Path(__file__).resolve().parent / "crazyflie_standins"
CC = shutil.which("gcc") or shutil.which("cc")

#: The firmware's functions the example calls, as stubs: the position controller returns the hover thrust (a_z = 0)
#: and counts its calls; the attitude PID records the setpoints it is given.
FIRMWARE_STUB = r"""
#include <stdio.h>
#include "stabilizer_types.h"
#include "controller.h"
#include "attitude_controller.h"
#include "position_controller.h"
static int position_calls, attitude_calls;
static float last_roll, last_pitch, last_yaw;
void attitudeControllerInit(const float updateDt) { (void)updateDt; }
bool attitudeControllerTest(void) { return true; }
void attitudeControllerCorrectAttitudePID(float ra, float pa, float ya, float rd, float pd, float yd,
                                          float *rr, float *pr, float *yr) {
    (void)ra; (void)pa; (void)ya;
    last_roll = rd; last_pitch = pd; last_yaw = yd; *rr = 0; *pr = 0; *yr = 0; ++attitude_calls;
}
void attitudeControllerCorrectRatePID(float a, float b, float c, float d, float e, float f) {
    (void)a; (void)b; (void)c; (void)d; (void)e; (void)f;
}
void attitudeControllerGetActuatorOutput(int16_t *roll, int16_t *pitch, int16_t *yaw) { *roll = *pitch = *yaw = 0; }
void positionControllerInit(void) {}
void positionController(float *thrust, attitude_t *attitude, const setpoint_t *setpoint, const state_t *state) {
    (void)attitude; (void)setpoint; (void)state;
    *thrust = HOVER; ++position_calls;
}
int main(void) {
    control_t control = {0};
    setpoint_t sp = {0};
    sensorData_t sensors = {0};
    state_t st = {0};
    stabilizerStep_t tick;
    sp.mode.x = sp.mode.y = sp.mode.z = modeAbs;
    sp.position.x = SPX; sp.position.y = SPY; sp.position.z = 1.0f;
    sp.acceleration.x = AX; sp.acceleration.y = AY;
    st.position.x = X; st.position.y = Y; st.position.z = 1.0f; st.attitude.yaw = YAW_DEG;
    controllerOutOfTreeInit();
    if (!controllerOutOfTreeTest()) return 1;
    for (tick = 1; tick <= 200; ++tick) {
        controllerOutOfTree(&control, &sp, &sensors, &st, tick);
        if (tick == 10) printf("%.9g %.9g %.9g\n", (double)last_roll, (double)last_pitch, (double)control.thrust);
    }
    printf("%d %d\n", position_calls, attitude_calls);
    return 0;
}
"""


@pytest.mark.skipif(CC is None, reason="needs a C compiler")
def test_crazyflie_example_compiles_and_gives_the_laws_setpoints_in_the_firmwares_frames(tmp_path, run_cli):
    code, _, err = run_cli("export", str(CERT), "--format", "crazyflie", "--out", str(tmp_path))
    assert code == 0, err
    cert = read_certificate(CERT)
    p = export_prefix(cert)
    assert (tmp_path / f"{p}_crazyflie.c").exists()
    x, y, spx, spy, yaw_deg, hover = 0.4, 0.3, 0.1, -0.05, 30.0, 36000.0  # the example's default hover thrust
    ax, ay = -0.2, 0.15  # the setpoint's acceleration (m/s^2, z-up frame): the feedforward
    defines = [f"-DX={x}f", f"-DY={y}f", f"-DSPX={spx}f", f"-DSPY={spy}f", f"-DYAW_DEG={yaw_deg}f",
               f"-DHOVER={hover}f", f"-DAX={ax}f", f"-DAY={ay}f"]
    (tmp_path / "firmware_stub.c").write_text(FIRMWARE_STUB)
    exe = tmp_path / "cf"
    flags = ["-std=gnu11", "-Wall", "-Wextra", "-Werror", "-Wdouble-promotion", "-Wmissing-prototypes",
             f"-D{p.upper()}_USE_FLOAT", "-I", str(STANDINS), "-I", str(tmp_path)]
    r = subprocess.run([CC, *flags, *defines, "-o", str(exe), str(tmp_path / f"{p}_crazyflie.c"),
                        str(tmp_path / f"{p}.c"), str(tmp_path / "firmware_stub.c"), "-lm"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    lines = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.splitlines()
    roll_deg, pitch_deg, thrust = map(float, lines[0].split())
    position_calls, attitude_calls = map(int, lines[1].split())
    assert (position_calls, attitude_calls) == (200 // 10, 200 // 2)  # 100 Hz and 500 Hz in 200 ticks of 1 kHz
    # the law in NED: north = x, east = -y, psi = -yaw; error measured minus setpoint
    ctrl = controller_from_certificate(cert, 100.0)
    xi = np.array([[x - spx, -(y - spy)]])
    tilt = ctrl.run(xi, np.array([-math.radians(yaw_deg)]), a_ff=np.array([[ax, -ay]]))["tilt_sp"][0]
    without = ctrl.run(xi, np.array([-math.radians(yaw_deg)]))["tilt_sp"][0]
    assert np.max(np.abs(np.degrees(tilt - without))) > 0.1  # the feedforward reached the law
    np.testing.assert_allclose([roll_deg, pitch_deg], np.degrees(tilt), rtol=1e-4, atol=1e-4)
    # signs by the firmware's convention: the vehicle is ahead (+x body) and left (+y body) of the setpoint,
    # so it must accelerate back and right: pitch > 0 (legacy pitch = -PID(vx)), roll > 0 (roll = -PID(vy))
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    body = np.array([c * (x - spx) + s * (y - spy), -s * (x - spx) + c * (y - spy)])
    assert np.all(body > 0) and roll_deg > 0 and pitch_deg > 0
    # hover thrust at a_z = 0, with the tilt compensation of the measured (level) attitude
    assert thrust == pytest.approx(hover, rel=1e-6)


def test_crazyflie_export_refuses_another_rate(tmp_path, run_cli):
    code, _, err = run_cli("export", str(CERT), "--format", "crazyflie", "--rate", "50", "--out", str(tmp_path))
    assert code == 2 and "100 Hz" in err and len(err.strip().splitlines()) == 1
    assert not any(tmp_path.iterdir())
