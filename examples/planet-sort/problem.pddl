(define (problem sort-2)
  (:domain sort)
  (:objects tablea tableb tablec -surface panda_hand_tcp -manipulator redblock greenblock -objs)
  (:init
    (on-surface redblock tablea)
    (on-surface greenblock tablea)
    (arm-empty panda_hand_tcp))
  (:goal (and
    (on-surface redblock tableb)
    (on-surface greenblock tablec)
    (arm-empty panda_hand_tcp))))
