"""Transports that carry the bus across processes and machines (issue 21).

The in-process :class:`~navstack.runtime.bus.Bus` stays the zero-copy local bus; a
transport bridges chosen topics, services and actions of it onto a network:
:mod:`navstack.runtime.transports.zenoh_link` (eclipse-zenoh), with ROS 2 CDR payloads
(:mod:`.payloads`), rmw_zenoh-style key expressions (:mod:`.keys`), NTP-style clock
estimation (:mod:`.clock_sync`) and configurable link impairments (:mod:`.impairments`).
"""
