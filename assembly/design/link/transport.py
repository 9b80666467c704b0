"""compas_eve's MQTT transport, made fit for a cell that must not lose what it reports: messages
go out with QoS 1 (paho keeps them, in order, until the broker acknowledges them, and
sends them again after a reconnect), subscriptions (its own and compas_eve Subscribers') are
renewed on every reconnect, a broker that is
down at start is connected to in the background, and a callback that raises never stops the
network thread."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any
from urllib.parse import urlsplit

from compas_eve.mqtt import MqttTransport

from assembly.errors import TreeError

log = logging.getLogger(__name__)
RECONNECT_DELAY = (0.5, 2.0)  # s, first and longest wait between reconnect attempts


def parse_broker_url(url: str) -> tuple[str, int]:
    """(host, port) of mqtt://HOST[:PORT] (port 1883 by default)."""
    parts = urlsplit(url)
    try:
        port = parts.port or 1883
    except ValueError:
        port = None
    if parts.scheme != "mqtt" or not parts.hostname or port is None or parts.path not in ("", "/"):
        raise TreeError(f"bad broker address {url!r}", "--bridge", hint="write mqtt://HOST:PORT, e.g. mqtt://127.0.0.1:1883")
    return parts.hostname, port


class LinkTransport(MqttTransport):
    """An MQTT connection for the design link (see the module docstring)."""

    def __init__(self, url: str, client_id: str):
        self.url = url
        host, port = parse_broker_url(url)
        self._listeners: dict[str, Callable[[bytes], None]] = {}
        self._sent: set[int] = set()  # message ids published (QoS 1)
        self._acked: set[int] = set()  # message ids the broker acknowledged (added by the network thread)
        self.connections = 0  # how many times it connected (1 + reconnects)
        try:
            super().__init__(host, port, client_id=client_id)
        except OSError as exc:  # the broker is down: keep trying in the background, the run goes on
            log.warning("broker %s not reachable (%s); connecting in the background", url, exc)
            self.client.connect_async(host, port)
            self.client.loop_start()
        self.client.reconnect_delay_set(*RECONNECT_DELAY)
        self.client.on_publish = lambda client, userdata, mid: self._acked.add(mid)

    def _on_connect(self, client, userdata, flags, rc) -> None:
        self.connections += 1
        super()._on_connect(client, userdata, flags, rc)
        for topic in self._listeners:
            client.subscribe(topic, qos=1)
        for subscription in self._local_callbacks:  # compas_eve Subscribers: "event:TOPIC:ID"
            client.subscribe(subscription.split(":")[1], qos=1)

    def listen(self, topic: str, callback: Callable[[bytes], None]) -> None:
        """Call `callback(payload)` with each raw message on `topic` (decoding is the caller's: a
        malformed message must be reported, not raised in the network thread)."""

        def deliver(client, userdata, message) -> None:
            try:
                callback(message.payload)
            except Exception:  # a bad message must never stop the network thread
                log.exception("handling a message on %s", topic)

        self._listeners[topic] = callback
        self.client.message_callback_add(topic, deliver)
        if self._is_connected:
            self.client.subscribe(topic, qos=1)

    def send(self, topic: str, data: Any, retain: bool = False) -> None:
        """Publish `data` (a dict or COMPAS object, encoded by compas_eve's JSON codec) with QoS 1:
        kept and re-sent until the broker has it, whatever happens to the connection."""
        self._sent.add(self.client.publish(topic, self.codec.encode(data), qos=1, retain=retain).mid)

    def unacknowledged(self) -> int:
        """Messages sent that the broker has not acknowledged yet."""
        done = self._sent & self._acked
        self._sent -= done
        self._acked -= done
        return len(self._sent)

    def close(self, timeout: float = 5.0) -> int:
        """Wait up to `timeout` s for the broker to acknowledge what was sent, then disconnect;
        returns how many messages it never acknowledged."""
        deadline = time.monotonic() + timeout
        while self.unacknowledged() and time.monotonic() < deadline:
            time.sleep(0.02)
        left = self.unacknowledged()
        self.client.disconnect()
        self.client.loop_stop()
        return left
