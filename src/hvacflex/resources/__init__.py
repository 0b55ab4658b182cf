"""Data shipped with hvacflex (package data; sources and licences in ``PROVENANCE.md``).

``nems_usep_2014/``  NEMS USEP half-hourly prices for 2014 (EMC Singapore)
``weather/``         Singapore Changi TMYx typical-year EPW (the default weather)
``bestest/``         ASHRAE Standard 140 Denver weather, case summary and example results
``building/``        the Maasoumy/BluSTL single-room data (a structural template)
``buildings/``       hvacflex's building descriptions (``office5``, ``room1``, BESTEST 600/900)
"""
