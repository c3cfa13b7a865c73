"""SUMO road networks: built-in roads built with netconvert (cached), any .net.xml read as
lanes and junctions, its drivable area and road edges, the ego's route as a road, and
random-trip demand."""
