"""The Foxglove WebSocket server of a running mission (``flyby_mission.live_view`` says what it forwards and why)."""

import foxglove
from rclpy.node import Node

from flyby_mission.live_view import DEFAULT_PORT, HOST
from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, frames, qos
from flyby_msgs_py.bag import jazzy_typestore
from flyby_msgs_py.runtime import main_for


class _Listener(foxglove.ServerListener):
    """Sends a late subscriber the last message of a latched topic (Foxglove has no latching of its own)."""

    def __init__(self, latched):
        self.latched = latched  # topic -> [channel, last raw message or None, its log time]

    def on_subscribe(self, client, channel):
        channel_, last, log_time = self.latched.get(channel.topic, (None, None, None))
        if last is not None:
            channel_.log(last, log_time=log_time)


class LiveViewNode(Node):
    """The Foxglove WebSocket server of a running mission; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_live_view', **kwargs)
        self.declare_parameter('port', DEFAULT_PORT)
        self.declare_parameter('namespaces', [''])
        self.declare_parameter('static_transforms', [''])
        namespaces = list(self.get_parameter('namespaces').value)
        typestore = jazzy_typestore()
        topics = c.topics_by_name(namespaces)
        types = {name: type_name for name, (_, type_name) in topics.items()}
        types.update({frames.TF_TOPIC: frames.TF_TYPE, frames.TF_STATIC_TOPIC: frames.TF_TYPE})
        self.channels = {}
        for name, type_name in types.items():
            definition, _ = typestore.generate_msgdef(type_name, ros_version=2)
            schema = foxglove.Schema(name=type_name, encoding='ros2msg', data=definition.encode())
            self.channels[name] = foxglove.Channel(name, schema=schema, message_encoding='cdr')
        latched = {c.absolute(t, ns) for t in c.LATCHED_TOPICS for ns in namespaces}
        self.latched = {name: [self.channels[name], None, 0] for name in [*latched, frames.TF_STATIC_TOPIC]
                        if name in self.channels}
        self.truth = frames.truth_topics(namespaces)
        self.clock_ns = 0
        self.server = foxglove.start_server(name='flyby', host=HOST, port=int(self.get_parameter('port').value),
                                            server_listener=_Listener(self.latched))
        static = [frames.parse_static(line) for line in self.get_parameter('static_transforms').value if line]
        if static:
            self._forward(frames.TF_STATIC_TOPIC, frames.tf_message_cdr(static))
        for name, (topic, type_name) in topics.items():
            self.create_subscription(c.message_class(type_name), name, self._forwarder(name),
                                     qos.recorder_qos_for(topic), raw=True)
        self.get_logger().info(f'Foxglove WebSocket server on ws://{HOST}:{self.server.port}')

    def _forward(self, name, raw):
        latched = self.latched.get(name)
        if latched is not None:
            latched[1:] = [raw, self.clock_ns]
        channel = self.channels[name]
        if channel.has_sinks():
            channel.log(raw, log_time=self.clock_ns)

    def _forwarder(self, name):
        if name == c.absolute(c.CLOCK):
            def forward(raw):
                self.clock_ns = convert.clock_cdr_to_ns(raw)
                self._forward(name, raw)
        elif name in self.truth:
            namespace = self.truth[name]
            tf_channel = self.channels[frames.TF_TOPIC]

            def forward(raw):
                self._forward(name, raw)
                tf = frames.tf_of_truth(raw, namespace) if tf_channel.has_sinks() else None
                if tf is not None:
                    tf_channel.log(tf, log_time=self.clock_ns)
        else:
            def forward(raw):
                self._forward(name, raw)
        return forward

    def close(self):
        """Stop the server; safe to call twice."""
        if self.server is not None:
            self.server.stop()
            self.server = None


def main(args=None):
    main_for(LiveViewNode, args)


if __name__ == '__main__':
    main()
