; Move the blue stick from table 1 to table 2 with either gripper.
(define (problem clutter-1)
  (:domain clutter)
  (:objects
    table1 table2 table3 table4 - surface
    l_gripper_tool_frame r_gripper_tool_frame - manipulator
    blue_stick_1 - stick)
  (:init
    (on-surface blue_stick_1 table1)
    (arm-empty l_gripper_tool_frame)
    (arm-empty r_gripper_tool_frame))
  (:goal (on-surface blue_stick_1 table2)))
