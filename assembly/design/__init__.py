"""The design model (elements, plates, precedence; `model`), the bridge a run writes its as-built
data through (`bridge`), and its live link to designers and other cells over MQTT (`link`)."""
