"""The recorder: every contract topic, subscribed raw, written as received into a rosbag2 MCAP bag.

The serialized CDR bytes go to the bag untouched (no deserialize/serialize round trip). The log
time of each message is simulation time: the stamp of the last ``/clock`` the recorder received (it records
that topic anyway; rclpy's time source would deserialize every clock message again and cost a ROS clock
query per message). Data reach
the disk every ``flush_period_s`` of simulation time, so a recorder killed with SIGKILL loses at
most that much (``python -m flyby_msgs_py.bag repair DIR`` rebuilds the index); SIGINT and SIGTERM
close the bag cleanly, after taking every message already on its way (``runtime.main_for``,
drain_on_signal): the launcher stops the recorder last, so the bag ends with the graph's last words.

The frames for viewers (``flyby_msgs_py.frames``) are written beside them: on ``/tf`` the transform of each truth
odometry (target and chasers), at the same log time; on ``/tf_static`` once, at the start, the mounts given in
``static_transforms`` (``frames.format_static`` lines, from the launcher).
"""

from rclpy.node import Node

from flyby_msgs_py import contract as c
from flyby_msgs_py import convert, frames, qos
from flyby_msgs_py.bag import BagWriter
from flyby_msgs_py.runtime import main_for


class RecorderNode(Node):
    """Raw recorder of the contract topics; see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__('flyby_recorder', **kwargs)
        self.declare_parameter('bag_dir', '')
        self.declare_parameter('namespaces', [''])
        self.declare_parameter('flush_period_s', 2.0)
        self.declare_parameter('static_transforms', [''])
        bag_dir = self.get_parameter('bag_dir').value
        if not bag_dir:
            raise ValueError('parameter bag_dir: required (directory of the bag to write)')
        namespaces = list(self.get_parameter('namespaces').value)

        topics = c.topics_by_name(namespaces)
        static = [frames.parse_static(line) for line in self.get_parameter('static_transforms').value if line]
        self.truth = frames.truth_topics(namespaces)
        flush_ns = int(self.get_parameter('flush_period_s').value * 1e9)
        self.writer = BagWriter(bag_dir, {**{name: t for name, (_, t) in topics.items()},
                                          frames.TF_TOPIC: frames.TF_TYPE, frames.TF_STATIC_TOPIC: frames.TF_TYPE},
                                flush_ns)
        self.count = 0
        self.clock_ns = 0
        if static:
            self.writer.write(frames.TF_STATIC_TOPIC, 0, frames.tf_message_cdr(static))
        for name, (topic, type_name) in topics.items():
            self.create_subscription(c.message_class(type_name), name, self._writer_for(name),
                                     qos.recorder_qos_for(topic), raw=True)

    def _writer_for(self, name):
        if name == c.absolute(c.CLOCK):
            def write(raw):
                self.clock_ns = convert.clock_cdr_to_ns(raw)
                self.writer.write(name, self.clock_ns, raw)
                self.count += 1
        elif name in self.truth:
            namespace = self.truth[name]

            def write(raw):
                self.writer.write(name, self.clock_ns, raw)
                self.count += 1
                tf = frames.tf_of_truth(raw, namespace)
                if tf is not None:
                    self.writer.write(frames.TF_TOPIC, self.clock_ns, tf)
        else:
            def write(raw):
                self.writer.write(name, self.clock_ns, raw)
                self.count += 1
        return write

    def close(self):
        """Close the bag (index, summary, metadata.yaml); safe to call twice."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None


def main(args=None):
    main_for(RecorderNode, args, drain_on_signal=True)


if __name__ == '__main__':
    main()
