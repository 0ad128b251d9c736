"""Vehicle links: the field robots' wire protocols and the transports that carry them.

Pure protocol and transport code -- no bus, no navigation.  ``tests/test_layers.py``
keeps it that way: this package imports only ``navstack.core`` (and the standard
library, pyserial, pynmea2, pyubx2, gpiozero).  The nodes that put a link on the bus
live in :mod:`navstack.nodes.vehicle_driver`; the simulated vehicles that answer on the
far side in :mod:`navstack.sim.vehicles`.

Codecs (pure functions, no I/O; every decode raises :class:`MalformedPacket`):

* :mod:`.rover_vcu` -- the rover's 12-character VCU command string (compat / corrected);
* :mod:`.rover_telemetry` -- the rover VCU's little-endian GNSS and odometry packets;
* :mod:`.golf_cart` -- the cart's ``struct '<fi'`` steering/speed packet;
* :mod:`.cart_sensors` -- the cart's sensor Arduino line format (wheel pulses, IMU);
* :mod:`.gnss` -- NMEA 0183 (GGA, RMC, VTG) and u-blox UBX (NAV-PVT) into NavSatFix.

Transports (:mod:`.transport`): UDP and serial (pyserial: real ports, ptys,
``loop://``), framing (:mod:`.framing`), link statistics, reconnect with back-off;
:mod:`.watchdog` declares a link lost when the far side goes silent; :mod:`.gpio` is the
digital-output convention (gpiozero).  Wire formats: ``docs/drivers.md``.
"""
