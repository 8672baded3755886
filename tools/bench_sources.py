"""The sources the default method is judged on, shared by fastest_ab.py and
method_table.py: kitti00 0-9, hilti2023 0-29, the simulator's 60 scans and la3dm sim_structured, read from
../shared/data beside the repository."""
import os

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "data")
# (name, --source, --scans)
SOURCES = [("kitti00", DATA + "/kitti00", "0:9"), ("hilti2023", DATA + "/hilti2023", "0:29"),
           ("sim60", "sim:scans=60", ""), ("la3dm", DATA + "/la3dm/sim_structured", "")]
