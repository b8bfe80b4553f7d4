; Put both cubes in the tray.
(define (problem tray)
  (:domain tabletop)
  (:objects panda_hand_tcp - gripper bench tray - surface red_cube blue_cube - cube)
  (:init
    (free panda_hand_tcp)
    (on red_cube bench)
    (on blue_cube bench))
  (:goal (and (on red_cube tray) (on blue_cube tray))))
