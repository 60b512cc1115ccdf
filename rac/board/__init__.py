"""The diagnostic hardware board (chapter 8): wire codec, simulator, client, plan execution.

- ``protocol``: frames and messages, encode/decode (byte order fixed there);
- ``stream``: a decoder for frames split, glued or behind garbage;
- ``channels``: the model's channel map and the hardware observer's literals;
- ``state``, ``sim``, ``control``: the asyncio board simulator and its fault-injection port;
- ``client``: the client controller (Algorithms 13-14, bounded);
- ``execute``: a repair plan's hardware steps through the board.
"""
