(define (problem sort-2)
 (:domain sort)
 (:objects tablea tableb -surface
  lgripper rgripper -manipulator
  redblock greenblock -objs)
 (:init (on-surface redblock tablea) (on-surface greenblock tablea)
  (arm-empty lgripper) (arm-empty rgripper))
 (:goal (and (on-surface redblock tableb) (on-surface greenblock tableb))))
