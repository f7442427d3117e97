"""The running robot: what it does between a context source and the HMI.

Each part is one job, and :class:`~homecog.robot.runtime.Runtime` puts them together:

- :mod:`~homecog.robot.attribution`: whose change is it — the robot's own switch reported back,
  or a person's (or an automation's);
- :mod:`~homecog.robot.holds`: never fight — a device a person switched is left alone while the
  situation is the same, or until the hold runs out;
- :mod:`~homecog.robot.journal`: what the robot did, when and why, and which of it was undone;
- :mod:`~homecog.robot.guidance`: what a person's switch teaches — an observed correction, or an
  undo of the robot's switch, learned as a rejection where it acted; bad input counted;
- :mod:`~homecog.robot.actor`: the robot acting on what it proposes (planning, IoT switches,
  its simulated body), out of the way of what a person holds;
- :mod:`~homecog.robot.settling`: the robot does not switch back its own switch while the home
  is as that switch left it;
- :mod:`~homecog.robot.events`: the live stream of what happens, for the HMI.

A simulated household that switches by its own wishes, and the robot and the household living
days together, are an evaluation: :mod:`homecog.evaluation.closed_loop`.
"""
