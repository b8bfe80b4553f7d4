; c on b on a on the bench: a goal of geometric atoms, achieved where the cubes are released.
(define (problem abc)
  (:domain tower)
  (:objects panda_hand_tcp - gripper bench - surface a b c - cube)
  (:init
    (free panda_hand_tcp))
  (:goal (and (on c b) (on b a) (on a bench))))
