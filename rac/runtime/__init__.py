"""The live runtime's logic, transport-free: what the ROS 1 nodes (``rac.ros1``) run and a
ROS 2 transport will run too.

- :mod:`status`: observations, diagnoses and board readings as diagnostic statuses;
- :mod:`values`: the values observers read from raw message bytes;
- :mod:`procs`: node liveness and cpu/mem samples of processes (psutil);
- :mod:`host`: the observer host, every observer of a model in one process;
- :mod:`diagnoser`: Algorithm 10's collection and the periodic diagnosis (§6.3, §6.4);
- :mod:`repairer`: Algorithm 11 with every step verified in the observations, and the
  rules that keep it off healthy nodes (confirmation, grace, budget, robot shutdown);
- :mod:`detached`: nodes the repairer starts, in sessions of their own (they outlive racc);
- :mod:`guardian` and :mod:`lifetime`: the process that starts such a node and stops it
  when the robot stops (they do not outlive the robot), and what racc tells it;
- :mod:`onecopy`: before a node is started, its old process is proven gone;
- :mod:`demo`: what a demo robot's node publishes and which faults it shows;
- :mod:`record`: the computation graph and properties CSV of a recording (§9.1.1).
"""
