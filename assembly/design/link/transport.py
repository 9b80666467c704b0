"""compas_eve's MQTT transport, made fit for a cell that must not lose what it reports, on a
broker it must log in to: messages go out with QoS 1 (paho keeps them, in order, until the broker
acknowledges them, and sends them again after a reconnect), subscriptions (its own and compas_eve
Subscribers') are renewed on every reconnect, and a callback that raises never stops the network
thread.

It logs in with the link's credentials and speaks TLS for mqtts:// (`assembly.design.link.security`),
which compas_eve's own constructor cannot do before it connects: the client is made here, then
connected once, synchronously. A broker that cannot be reached or refuses the login is a
`LinkError` at once; after that, a lost connection is retried in the background and `lost_for()`
says for how long it has been down (the links make it a fault past the stated limit), and a
broker that refuses a reconnect (a revoked login) is `refused`."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import paho.mqtt.client as mqtt
from compas_eve.mqtt import MqttTransport
from paho.mqtt.enums import CallbackAPIVersion

from assembly.design.link.security import LinkError, LinkSecurity, parse_broker_url

log = logging.getLogger(__name__)
RECONNECT_DELAY = (0.5, 2.0)  # s, first and longest wait between reconnect attempts
CONNECT_TIMEOUT = 30.0  # s for the broker to answer the first login (generous: a loaded machine)


class LinkTransport(MqttTransport):
    """An MQTT connection for the design link (see the module docstring)."""

    def __init__(self, url: str, client_id: str, security: LinkSecurity | None = None,
                 connect_timeout: float = CONNECT_TIMEOUT):
        self.url = url
        broker = parse_broker_url(url)
        self.security = security or LinkSecurity()
        self._listeners: dict[str, Callable[[bytes], None]] = {}
        self._sent: set[int] = set()  # message ids published (QoS 1)
        self._acked: set[int] = set()  # message ids the broker acknowledged (added by the network thread)
        self.connections = 0  # how many times it connected (1 + reconnects)
        self.refused: str | None = None  # why the broker last refused the login, if it did
        self._down_since: float | None = time.monotonic()  # None while connected
        self._answered = threading.Event()
        # compas_eve's Transport base (codec, ids) without MqttTransport.__init__, which connects at once
        super(MqttTransport, self).__init__(codec=None)
        self.host, self.port = broker.host, broker.port
        self._is_connected = False
        self._local_callbacks: dict = {}
        self.client = mqtt.Client(client_id=client_id, callback_api_version=CallbackAPIVersion.VERSION1)
        self.client.suppress_exceptions = True  # a compas_eve Subscriber's decode error is logged, not fatal
        self.client.on_connect = self._on_connect
        self.client.on_disconnect = self._on_disconnect
        self.client.on_publish = lambda client, userdata, mid: self._acked.add(mid)
        self.client.reconnect_delay_set(*RECONNECT_DELAY)  # type: ignore[arg-type] # paho takes float seconds
        if self.security.username is not None:
            self.client.username_pw_set(self.security.username, self.security.password)
        if self.security.tls_files and not broker.tls:
            raise LinkError(f"TLS files given for a plain address {url}", "--bridge", hint="write mqtts://")
        if broker.tls:
            self.client.tls_set(**self.security.tls_options())
        self._connect(broker, connect_timeout)

    def _connect(self, broker, timeout: float) -> None:
        try:
            self.client.connect(broker.host, broker.port)
        except OSError as exc:  # refused, unreachable, or a TLS handshake that failed (ssl.SSLError)
            raise LinkError(f"cannot reach the broker {broker}: {exc}", "--bridge",
                            hint="is it running, and is the address (and for mqtts:// the CA) right?") from None
        self.client.loop_start()
        if not self._answered.wait(timeout) or self.refused is not None:
            self.client.loop_stop()
            self.client.disconnect()
            why = self.refused or f"no answer within {timeout:g} s"
            raise LinkError(f"the broker {broker} refused the connection: {why}", "--bridge",
                            hint="check the user name and password (--credentials, or FVTREE_MQTT_USERNAME "
                                 "and FVTREE_MQTT_PASSWORD)")

    def _on_connect(self, client, userdata, flags, rc) -> None:
        if rc != 0:  # refused: paho retries; the links make this a fault
            self.refused = mqtt.connack_string(rc)
            log.error("broker %s refused the connection: %s", self.url, self.refused)
            self._answered.set()
            return
        self.refused = None
        self._down_since = None
        self.connections += 1
        super()._on_connect(client, userdata, flags, rc)
        for topic in self._listeners:
            client.subscribe(topic, qos=1)
        for subscription in self._local_callbacks:  # compas_eve Subscribers: "event:TOPIC:ID"
            client.subscribe(subscription.split(":")[1], qos=1)
        self._answered.set()

    def _on_disconnect(self, client, userdata, rc) -> None:
        self._is_connected = False
        if self._down_since is None:
            self._down_since = time.monotonic()

    def lost_for(self) -> float:
        """Seconds since the connection was lost (0 while connected)."""
        since = self._down_since
        return 0.0 if since is None else time.monotonic() - since

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
        self.send_raw(topic, self.codec.encode(data), retain)

    def send_raw(self, topic: str, payload: bytes | str, retain: bool = False) -> None:
        """Publish an encoded payload with QoS 1 (see `send`)."""
        self._sent.add(self.client.publish(topic, payload, qos=1, retain=retain).mid)

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
        while self.unacknowledged() and time.monotonic() < deadline and self.refused is None:
            time.sleep(0.02)
        left = self.unacknowledged()
        self.client.disconnect()
        self.client.loop_stop()
        return left
