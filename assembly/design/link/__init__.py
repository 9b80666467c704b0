"""The live link between a design model and the outside: the design as COMPAS data, the topics and
messages of the MQTT bridge (through `compas_eve`), the bridge a run publishes on, and the
coordinator that hands out the elements of one design to several cells."""
