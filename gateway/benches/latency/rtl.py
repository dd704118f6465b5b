# The baseline: ten lines of pymavlink that answer a low-battery SYS_STATUS
# with RTL, as the gateway's project does. Usage: rtl.py ADDRESS
import sys
from pymavlink import mavutil
m = mavutil.mavlink_connection(sys.argv[1], source_system=1, source_component=191)
low = False
while True:
    s = m.recv_match(type="SYS_STATUS", blocking=True)
    if 0 <= s.battery_remaining < 25 and not low:
        m.mav.command_long_send(1, 1, 20, 0, 0, 0, 0, 0, 0, 0, 0)
    low = 0 <= s.battery_remaining < 30 and (low or s.battery_remaining < 25)
