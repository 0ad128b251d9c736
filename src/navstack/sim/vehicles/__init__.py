"""Simulated vehicles on the far side of a real link (hardware-in-the-loop, no hardware).

* :mod:`.firmware` -- what runs on the vehicles' controllers: the rover's VCU (decodes
  the command string, holds it, stops on its own watchdog), the golf cart's Uno (speed
  PID with output 0..21, steering stepper with a finite step rate) and sensor Mega
  (wheel pulses, calibrated IMU lines);
* :mod:`.pty` -- pseudo-terminal pairs behind a stable symlink, and the vehicle's end
  (the pty master) as a transport;
* :mod:`.far_side` -- the vehicle's link endpoints, one reader thread per link, with
  mute / kill / restart for link-loss tests;
* :mod:`.bridge` -- :class:`~.bridge.HilBridgeNode`, which couples the firmware to the
  simulator's robot on the stack's clock and meets the wall-clock I/O in lock step.
"""
